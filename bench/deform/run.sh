#!/usr/bin/env bash
# Issue 39's figures: the deform stage's cost against skinned vertex count, its
# share of a `fast` frame, refit against rebuild while the arm bends, the motion
# vectors against Cycles' Vector pass, and `reference` against Cycles on the
# character as Blender exported it.
#
#   bench/deform/run.sh [OUTDIR] [ARM_SIZES]
# ARM_SIZES: the arm's RINGSxSEGMENTS, default "100x100 400x250" (10k and 100k skinned
# vertices; add 1000x1000 for 1M). Needs Debian's blender (./bootstrap.sh quality
# installs it) and a build in build/.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
out=${1:-$root/bench-out/deform}
sizes=${2:-100x100 400x250}
photonfarm=$root/build/worker/photonfarm
bench=$root/build/bench/deform/deform_bench
mkdir -p "$out"
blend() { blender -b --factory-startup --python "$@" >/dev/null 2>&1; }

for size in $sizes; do
  dir=$out/arm-$size
  blend "$here/make_character.py" -- "$dir" "${size%x*}" "${size#*x}"
  echo "== arm $size: host deform, refit against rebuild"
  "$bench" cost "$dir/character.gltf" 1 2 12 24
  echo "== arm $size: fast 640x480, frames 1-3 (deform row and frame time)"
  "$photonfarm" render "$dir/character.gltf" --frames 1-3 --quality fast --size 640x480 \
    --timings -o "$dir/fast.####.exr" 2>&1 | grep -E '^  deform |^\[' || true
done

scene=$root/scenes/character/character.gltf
echo "== motion vectors against Cycles' Vector pass (frame 12, 128x128)"
blend "$here/cycles_vectors.py" -- "$scene" "$out/cycles-vectors.exr" 128 128 12
"$photonfarm" render "$scene" --frame 12 --size 128x128 --quality preview \
  -o "$out/pf-vectors.####.exr" >/dev/null 2>&1
"$bench" vectors "$out/cycles-vectors.exr" "$out/pf-vectors.0012.exr"

echo "== reference (64 spp) against Cycles (256 spp), 256x256"
for frame in 1 24; do
  blend "$root/bench/materials/cycles_import_render.py" -- "$scene" "$out/cycles-$frame.exr" \
    256 256 256 64 "$frame"
  "$photonfarm" render "$scene" --frame "$frame" --quality reference --spp 64 --size 256x256 \
    --filter blackman-harris -o "$out/pf-ref.####.exr" >/dev/null 2>&1
  echo "-- frame $frame"
  "$photonfarm" compare "$out/pf-ref.$(printf %04d "$frame").exr" "$out/cycles-$frame.exr" --rgb \
    2>/dev/null | grep -E 'relMSE|^[RGB] '
done

echo "== the control: Specular 0 in Blender, so neither model has a specular layer (frames 1, 24)"
control=$out/specular-0
blend "$here/make_character.py" -- "$control" 24 16 0
for frame in 1 24; do
  blend "$root/bench/materials/cycles_import_render.py" -- "$control/character.gltf" \
    "$control/cycles-$frame.exr" 256 256 256 64 "$frame"
  "$photonfarm" render "$control/character.gltf" --frame "$frame" --quality reference --spp 64 \
    --size 256x256 --filter blackman-harris -o "$control/pf-ref.####.exr" >/dev/null 2>&1
  echo "-- frame $frame"
  "$photonfarm" compare "$control/pf-ref.$(printf %04d "$frame").exr" "$control/cycles-$frame.exr" \
    --rgb 2>/dev/null | grep -E 'relMSE|^[RGB] '
done
