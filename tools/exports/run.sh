#!/usr/bin/env bash
# Exports the bundled scenes the way real tools do, for tests/exports.rs:
#
#   tools/exports/run.sh [OUT_DIR]        (default: a fresh directory under target/)
#
# Writes OUT_DIR/foliage.glb (the textured source scene, tools/exports/
# make_foliage.mjs), then for data/{corner_bunny,sun,occluded}.glb and
# foliage.glb one file per tool and option, named SOURCE.TAG.glb:
#   pack-c, pack-cc      gltfpack -c / -cc (EXT_meshopt_compression, its filters,
#                        KHR_mesh_quantization)
#   pack-q               gltfpack without -c (KHR_mesh_quantization only)
#   pack-mi              gltfpack -mi (EXT_mesh_gpu_instancing)
#   gt-meshopt           gltf-transform meshopt
#   gt-quantize          gltf-transform quantize
#   gt-instance          gltf-transform instance (EXT_mesh_gpu_instancing)
#   gt-webp              gltf-transform webp (EXT_texture_webp)
#   gt-optimize          gltf-transform optimize --compress meshopt --texture-compress webp
#   gt-draco-meshopt     gltf-transform draco, then the command gibake's refusal
#                        gives: gltf-transform meshopt
#   gt-avif-webp         gltf-transform avif, then gibake's command: gltf-transform webp
# and OUT_DIR/refused/: the Draco and AVIF files themselves (gibake refuses
# them with the command above), and KTX2 ones when KTX-Software is installed.
# Judge them with:
#   GIBAKE_EXPORTS=OUT_DIR cargo test --release -p gibake --test end_to_end exports::sweep -- --ignored
#
# Needs gltfpack (Debian: apt-get install gltfpack) and node/npm; glTF
# Transform (pinned in tools/exports/package.json) is installed under
# target/exports-node, never in the source tree. The committed files in
# data/exports/ are a small subset of this output.
set -euo pipefail
cd "$(dirname "$0")/../.."
root=$(pwd)
out="${1:-$root/target/exports-$(date +%Y%m%d-%H%M%S)}"
node_dir="$root/target/exports-node"
mkdir -p "$out/refused" "$node_dir"
cp tools/exports/package.json tools/exports/package-lock.json tools/exports/make_foliage.mjs "$node_dir/"
(cd "$node_dir" && npm ci --silent --no-audit --no-fund)
gt() { "$node_dir/node_modules/.bin/gltf-transform" "$@" >/dev/null; }
command -v gltfpack >/dev/null || { echo "run.sh: gltfpack is missing (apt-get install gltfpack)" >&2; exit 2; }

node "$node_dir/make_foliage.mjs" "$out/foliage.glb"
for src in data/corner_bunny.glb data/sun.glb data/occluded.glb "$out/foliage.glb"; do
    name=$(basename "$src" .glb)
    o="$out/$name"
    echo "== $name"
    # -kn -km -ke keep node names, materials and extras (the moving objects' marks).
    gltfpack -i "$src" -o "$o.pack-c.glb" -c -kn -km -ke >/dev/null
    gltfpack -i "$src" -o "$o.pack-cc.glb" -cc -kn -km -ke >/dev/null
    gltfpack -i "$src" -o "$o.pack-q.glb" -kn -km -ke >/dev/null
    # -mi without -kn: gltfpack then merges named nodes into instances (the
    # moving leaf of foliage.glb becomes a static instance; see data/README.md).
    gltfpack -i "$src" -o "$o.pack-mi.glb" -mi -km -ke >/dev/null
    gt meshopt "$src" "$o.gt-meshopt.glb"
    gt quantize "$src" "$o.gt-quantize.glb"
    gt instance "$src" "$o.gt-instance.glb" --min 2
    if [ "$name" = foliage ]; then
        gt webp "$src" "$o.gt-webp.glb"
        gt optimize "$src" "$o.gt-optimize.glb" --compress meshopt --texture-compress webp \
            --simplify false --palette false --join false
        gt avif "$src" "$out/refused/$name.gt-avif.glb"
        gt webp "$out/refused/$name.gt-avif.glb" "$o.gt-avif-webp.glb"
        if command -v ktx >/dev/null || command -v toktx >/dev/null; then
            gt uastc "$src" "$out/refused/$name.gt-uastc.glb"
            gt etc1s "$src" "$out/refused/$name.gt-etc1s.glb"
        else
            echo "   (no KTX-Software: KTX2 exports skipped)"
        fi
    fi
    gt draco "$src" "$out/refused/$name.gt-draco.glb"
    gt meshopt "$out/refused/$name.gt-draco.glb" "$o.gt-draco-meshopt.glb"
done
ls -l "$out" "$out/refused"
echo "judge: GIBAKE_EXPORTS=$out cargo test --release -p gibake --test end_to_end exports::sweep -- --ignored --nocapture"
