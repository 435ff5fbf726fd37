#!/usr/bin/env bash
# The every-bounce validation of gibake's CPU reference against Mitsuba 3
# (docs/reference.md, "Every bounce against Mitsuba 3"). Not run by CI: it
# needs Python with Mitsuba and numpy, and takes tens of minutes on 2 cores.
#
#   python3 -m venv /tmp/mitsuba-venv && /tmp/mitsuba-venv/bin/pip install mitsuba numpy
#   tools/mitsuba/every_bounce.sh [OUT_DIR] [CASE...]
#
# CASE: corner, room, living_room, rooms, arena (default: all). Each exports
# the scene with `export_obj --every-bounce` (gibake's direct, one-bounce and
# every-bounce renders) and runs crates/reference/validation/mitsuba_validate.py
# on it. Environment: PYTHON (default /tmp/mitsuba-venv/bin/python).
set -euo pipefail
root=$(cd "$(dirname "$0")/../.." && pwd)
out=${1:-/tmp/gibake-mitsuba-every}
shift || true
cases=("$@")
[ ${#cases[@]} -eq 0 ] && cases=(corner room living_room rooms arena)
py=${PYTHON:-/tmp/mitsuba-venv/bin/python}
cd "$root"
cargo build --release -p gibake-reference --example export_obj
exe=$(cargo metadata --format-version 1 --no-deps | "$py" -c 'import json,sys; print(json.load(sys.stdin)["target_directory"])')/release/examples/export_obj
validate=crates/reference/validation/mitsuba_validate.py
levels=data/levels
for c in "${cases[@]}"; do
    d=$out/$c
    echo "=== $c"
    case $c in
    corner) "$exe" "$d" --size 128 --spp 1024 --every-bounce
            "$py" $validate "$d" ;;
    room)   "$exe" "$d" --room --size 128 --spp 1024 --every-bounce
            "$py" $validate "$d" ;;
    # The bundled levels with the sun and camera of data/levels/levels.json
    # (no textures: Mitsuba gets base colour factors, and so does gibake here).
    living_room)
            "$exe" "$d" --scene $levels/living_room/living_room.glb --time 0.5 \
                --sun 173.1,60,3 --look-at -2.93,2.21,-1.89,-0.1,1.98,2.23,75 \
                --size 64 --spp 512 --every-bounce
            "$py" $validate "$d" ;;
    rooms)  "$exe" "$d" --scene $levels/rooms/rooms.glb --time 0.5 \
                --sun 296.9,17,3 --look-at 3.5,2.2,4.5,-4,1.2,-2,75 \
                --size 64 --spp 512 --every-bounce
            "$py" $validate "$d" ;;
    # Albedo 1 through small openings: Mitsuba's roulette (survival at most
    # 0.95) has infinite variance here, so it runs without roulette, cut at
    # gibake's cap (path depth 1026 = 1024 bounces).
    arena)  "$exe" "$d" --scene $levels/arena/zdm2.glb --time 0.5 \
                --sun 152.9,33.4,3 --look-at 11.8,1.5,7.54,11.8,0.5,-2,75 \
                --size 48 --spp 256 --every-bounce
            "$py" $validate "$d" --rr-depth 1026 --max-depth 1026 ;;
    *) echo "unknown case $c" >&2; exit 2 ;;
    esac
done
