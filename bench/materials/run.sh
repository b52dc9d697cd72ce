#!/usr/bin/env bash
# Issue 38's user check: the Blender-exported room (make_room.py) rendered by
# Cycles through Blender's importer and by every photonfarm preset, with the
# error and the channel means of each against Cycles.
#
#   bench/materials/run.sh [OUTDIR] [WxH] [CYCLES_SPP] [REFERENCE_SPP]
# PF_MATERIALS_SCENES picks rooms (default: panel lamps textured string coated ortho unlit
# velvet).
# Needs Debian's blender (./bootstrap.sh quality installs it) and a build in build/.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
root=$(cd "$here/../.." && pwd)
out=${1:-$root/bench-out/materials}
size=${2:-160x120}
cycles_spp=${3:-512}
reference_spp=${4:-64}
photonfarm=$root/build/worker/photonfarm
mkdir -p "$out"
blender -b --factory-startup --python "$here/make_room.py" -- "$out" >/dev/null
for scene in ${PF_MATERIALS_SCENES:-panel lamps textured string coated ortho unlit velvet}; do
  blender -b --factory-startup --python "$here/cycles_import_render.py" -- \
    "$out/room-$scene.gltf" "$out/cycles-$scene.exr" "${size%x*}" "${size#*x}" "$cycles_spp" \
    >/dev/null
  for quality in preview fast final reference; do
    spp=()
    [ "$quality" = reference ] && spp=(--spp "$reference_spp")
    # render's progress line ends "frame 1  N ms  FILE": the frame's time.
    frame_ms=$("$photonfarm" render "$out/room-$scene.gltf" --frame 1 --size "$size" \
      --quality "$quality" "${spp[@]}" --filter blackman-harris \
      -o "$out/pf-$scene-$quality.exr" 2>&1 | grep -o '[0-9.]* ms' | tail -1)
    echo "== room-$scene $quality ($frame_ms)"
    "$photonfarm" compare "$out/pf-$scene-$quality.exr" "$out/cycles-$scene.exr" --rgb 2>/dev/null |
      grep -E 'relMSE|^[RGB] '
  done
done
