#!/bin/sh
# Bakes the levels a change touched and diffs each against its last accepted
# asset: what a player sees differently, as a Markdown summary with pictures.
# Exit 0: no visible change; 1: a visible change; 2: a level failed to bake
# or to diff. docs/pipeline.md, "Diffing bakes in CI", explains each step.
#
#   BASE        the accepted revision to compare with (default origin/main)
#   LEVELS      the levels' directory in the repository (default levels)
#   ACCEPTED    the last accepted assets, ACCEPTED/NAME.gibake (default baked)
#   OUT         new assets, pictures and summary.md go here (default ci-diff)
#   BAKE_FLAGS  the flags the accepted assets were baked with (default none)
#   DIFF_FLAGS  more flags for gibake diff: --max-flip, --view, --time ...
set -u
BASE=${BASE:-origin/main}
LEVELS=${LEVELS:-levels}
ACCEPTED=${ACCEPTED:-baked}
OUT=${OUT:-ci-diff}
BAKE_FLAGS=${BAKE_FLAGS:-}
DIFF_FLAGS=${DIFF_FLAGS:-}

mkdir -p "$OUT/base" "$OUT/new" "$OUT/pictures" || exit 2
# The levels as they were at BASE (a .gltf level keeps its .bin and textures).
if git cat-file -e "$BASE:$LEVELS" 2>/dev/null; then
    git archive "$BASE" "$LEVELS" | tar -x -C "$OUT/base" || exit 2
fi
# The levels the change added, modified or renamed.
git -c core.quotePath=false diff --name-only --diff-filter=AMR "$BASE" -- "$LEVELS" |
    grep -E '\.(glb|gltf)$' > "$OUT/levels.txt"
summary="$OUT/summary.md"
printf '# Baked lighting: what changed since %s\n\n' "$BASE" > "$summary"
worst=0
while IFS= read -r level; do
    name=$(basename "$level")
    name=${name%.*}
    # shellcheck disable=SC2086 # the flags are words
    if ! gibake bake "$level" -o "$OUT/new/$name.gibake" $BAKE_FLAGS < /dev/null; then
        printf '## %s: **FAILED** to bake (see the job log)\n\n' "$level" >> "$summary"
        worst=2
        continue
    fi
    if [ ! -d "$ACCEPTED/$name.gibake" ] || [ ! -f "$OUT/base/$level" ]; then
        printf '## %s: a new level, no accepted asset to compare with\n\n' "$level" >> "$summary"
        continue
    fi
    # shellcheck disable=SC2086
    gibake diff "$ACCEPTED/$name.gibake" "$OUT/new/$name.gibake" \
        --scene "$OUT/base/$level" --scene "$level" \
        --images "$OUT/pictures/$name" --markdown "$OUT/$name.diff.md" \
        $DIFF_FLAGS > "$OUT/$name.diff.txt" < /dev/null
    rc=$?
    tail -n 3 "$OUT/$name.diff.txt"
    if [ -f "$OUT/$name.diff.md" ] && [ $rc -lt 2 ]; then
        sed "s|^## gibake diff:|## $name:|" "$OUT/$name.diff.md" >> "$summary"
        printf '\n' >> "$summary"
    else
        printf '## %s: **FAILED** to diff (see the job log)\n\n' "$level" >> "$summary"
    fi
    [ $rc -gt $worst ] && worst=$rc
done < "$OUT/levels.txt"
[ $worst -eq 0 ] && printf 'No visible change.\n' >> "$summary"
exit $worst
