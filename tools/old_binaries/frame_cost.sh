#!/usr/bin/env bash
# Frame cost of today's gibake against an earlier binary (c2145de) on the
# real levels with their sun and camera written into the file
# (levels_with_flags.py): per level, each binary's default bake and today's
# `--bounces 1`, rendered at 480x270 without supersampling, 3 frames (the
# first a warm-up), 3 repetitions alternating; then the table of medians
# and paired ratios (docs/results.md, "The real levels with their flags in
# the file").
#
#   tools/old_binaries/frame_cost.sh OLD_GIBAKE NEW_GIBAKE WORK_DIR [LEVEL...]
#
# Levels the old binary cannot bake (its own limits: the living room's
# NaN, EXT_texture_webp, EXT_meshopt_compression) are reported and skipped.
set -euo pipefail
old=$(realpath "$1"); new=$(realpath "$2"); work=$3; shift 3
here=$(dirname "$(realpath "$0")")
mkdir -p "$work"
python3 "$here/levels_with_flags.py" "$work/levels" >/dev/null
cd "$work"
mkdir -p a s
levels=("$@")
if [ ${#levels[@]} -eq 0 ]; then
  mapfile -t levels < <(python3 -c "import json; print('\n'.join(x['name'] for x in json.load(open('levels/list.json'))))")
fi
done_levels=()
for n in "${levels[@]}"; do
  f=$(python3 -c "import json,sys; print([x['file'] for x in json.load(open('levels/list.json')) if x['name']==sys.argv[1]][0])" "$n")
  if ! "$old" bake "levels/$f" -o "a/$n-old.gibake" --force >/dev/null 2>"a/$n-old.err"; then
    echo "$n: the earlier binary cannot bake it: $(grep -v XDG "a/$n-old.err" | tail -1)"
    continue
  fi
  "$new" bake "levels/$f" -o "a/$n-new.gibake" --force >/dev/null 2>&1
  "$new" bake "levels/$f" -o "a/$n-one.gibake" --bounces 1 --force >/dev/null 2>&1
  for rep in 1 2 3; do
    for c in old new one; do
      b=$new; [ $c = old ] && b=$old
      "$b" render "levels/$f" --bake "a/$n-$c.gibake" --width 480 --height 270 --ssaa 1 \
        --frames 3 --stats "s/$n-$c-$rep.json" -o "a/frame.exr" >/dev/null 2>&1
    done
  done
  done_levels+=("$n")
done
python3 - "${done_levels[@]}" <<'EOF'
import glob, json, statistics as S, sys
def stats(f):
    fr = json.load(open(f))['frames'][1:]
    names = [p['pass'] for p in fr[0]['passes_ms']]
    med = {n: S.median([q['ms'] for x in fr for q in x['passes_ms'] if q['pass'] == n]) for n in names}
    return sum(med.values()), med.get('shade', 0.0), fr[0].get('static_vpls')
print('| level | earlier: frame / shade ms (VPLs) | today: frame / shade ms (VPLs) | today ÷ earlier: frame | shade | today `--bounces 1` ÷ earlier: frame | shade |')
print('|---|---|---|---|---|---|---|')
for n in sys.argv[1:]:
    r = {c: [stats(f) for f in sorted(glob.glob(f's/{n}-{c}-*.json'))] for c in ('old', 'new', 'one')}
    ratio = lambda a, k: S.median([x[k] / y[k] for x, y in zip(r[a], r['old']) if y[k] > 0])
    med = lambda c, k: S.median([x[k] for x in r[c]])
    print(f"| {n} | {med('old', 0):.0f} / {med('old', 1):.0f} ({r['old'][0][2]}) | {med('new', 0):.0f} / {med('new', 1):.0f} ({r['new'][0][2]}) "
          f"| {ratio('new', 0):.2f}× | {ratio('new', 1):.2f}× | {ratio('one', 0):.2f}× | {ratio('one', 1):.2f}× |")
EOF
