#!/bin/bash
# The GPU figures issues 43 and 44 ask for, in one short run on a device machine, from
# the bundle bench/gpu/bundle.sh made (BUNDLE, default gpu-bundle):
#   - the BIH of 1M triangles: build (tree read back, nodes kept) and refit, wall and GPU;
#   - 1M photons traced and gridded (photon_bench, the repository's scenes);
#   - the LPV propagation where each site runs it (lpv_bench sites);
#   - fast and final frames of the Cornell box at 640x480 and 1920x1080, twice each (the
#     second with the shader cache warm), every stage row printed: frame wall against the
#     GPU's busy time.
# Output goes to stdout and, with the frames, to $OUT (the device tool's folder; else
# /tmp/device-check). SCALE=quick runs small sizes, to check the script on lavapipe.
set -u
bundle=${1:-gpu-bundle}
out=${OUT:-/tmp/device-check}
mkdir -p "$out"
export LD_LIBRARY_PATH="$PWD/$bundle/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
# The NVIDIA driver's ICD, where one is installed (the loader finds the others itself).
for icd in /usr/share/vulkan/icd.d/nvidia_icd*.json /etc/vulkan/icd.d/nvidia_icd*.json; do
    if [ -f "$icd" ]; then
        export VK_DRIVER_FILES="$icd"
        break
    fi
done
bin=$bundle/bin
triangles=1000000 photons=1000000 sizes="640x480 1920x1080" limit=150
if [ "${SCALE:-}" = quick ]; then
    triangles=20000 photons=20000 sizes="160x120" limit=300
fi
step() {
    echo "== $*"
    timeout "$limit" "$@" 2>&1
    echo "(exit $?)"
}
step "$bin/photonfarm" devices
step "$bin/bih_refit_bench" "$triangles"
step "$bin/photon_bench" "$photons" scenes
step "$bin/lpv_bench" sites
for quality in fast final; do
    for size in $sizes; do
        for round in 1 2; do
            step "$bin/photonfarm" render scenes/cornell/cornell.gltf --frame 1 \
                --quality "$quality" --size "$size" --timings --cache-dir "$out/cache" \
                -o "$out/$quality-$size-$round.exr"
        done
    done
done
