#!/usr/bin/env bash
# Issue 50's cost bars: what the later bounces cost against the first bounce
# alone, one binary, side by side in one run — per level the bake time (the
# stages' sum of `gibake bake --json`), the asset's bytes, and the frame at
# 480×270 (`gibake render --frames 3 --stats`, frames 2–3, the two bakes
# alternating twice), each level with its camera, sun and moving objects
# of data/levels/levels.json. Prints a Markdown table (bars: bake ≤ 3×,
# asset ≤ 2×, frame ≤ 1.3×).
#
#   scripts/later-cost.sh [LEVEL...]      (default: eight interiors)
#
#   GIBAKE   the binary (default: target/release/gibake, built if missing)
set -euo pipefail
cd "$(dirname "$0")/.."
G=${GIBAKE:-target/release/gibake}
[ -x "$G" ] || cargo build --release -p gibake
LEVELS=${*:-living_room rooms arena gallery house city deathmatch dungeon}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
python3 - "$LEVELS" > "$work/levels.txt" <<'PY'
import json, sys
want = sys.argv[1].split()
d = json.load(open("data/levels/levels.json"))
for l in (d["levels"] if isinstance(d, dict) else d):
    if l["name"] not in want:
        continue
    a = ["data/levels/" + l["file"]]
    if "sun" in l:
        s = l["sun"]
        a += ["--sun", f"{s['azimuth']},{s['elevation']}", "--sun-irradiance", str(s.get("irradiance", 1))]
    for p in l.get("dynamic", []):
        a += ["--dynamic", p]
    c = l["camera"]
    look = ",".join(str(x) for x in [*c["eye"], *c["target"], c.get("fov", 60)])
    print(l["name"], look, "\x1f".join(a))
PY
echo "| level | bake | asset | frame (min–max, median ratio) |"
echo "|---|---|---|---|"
while read -r name look rest; do
    IFS=$'\x1f' read -r -a args <<< "$rest"
    for b in one every; do
        extra=()
        [ "$b" = one ] && extra=(--bounces 1)
        "$G" bake "${args[@]}" "${extra[@]}" -o "$work/$b.gibake" --json > "$work/$b.json" 2>/dev/null
    done
    for r in 1 2; do
        for b in one every; do
            "$G" render "${args[@]}" --bake "$work/$b.gibake" --look-at="$look" \
                --width 480 --height 270 --frames 3 --stats "$work/st_${b}_$r.json" \
                -o "$work/f.exr" > /dev/null 2>&1
        done
    done
    python3 - "$work" "$name" <<'PY'
import json, os, statistics, sys
work, name = sys.argv[1:]
def bake(b):
    st = json.load(open(f"{work}/{b}.json"))["stages"]
    d = f"{work}/{b}.gibake"
    return sum(s["seconds"] for s in st), sum(os.path.getsize(os.path.join(d, f)) for f in os.listdir(d)) / 2**20
def frames(b):
    out = []
    for r in (1, 2):
        out += [f["wall_seconds"] * 1000 for f in json.load(open(f"{work}/st_{b}_{r}.json"))["frames"][1:]]
    return out
(t1, a1), (t2, a2) = bake("one"), bake("every")
f1, f2 = frames("one"), frames("every")
ratio = statistics.median(f2) / statistics.median(f1)
print(f"| {name} | {t1:.2f} → {t2:.2f} s ({t2 / t1:.1f}×) | {a1:.1f} → {a2:.1f} MiB ({a2 / a1:.2f}×) "
      f"| {min(f1):.0f}–{max(f1):.0f} → {min(f2):.0f}–{max(f2):.0f} ms ({ratio:.2f}×) |")
PY
done < "$work/levels.txt"
