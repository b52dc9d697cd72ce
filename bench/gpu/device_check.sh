#!/bin/bash
# The GPU figures issues 43 and 44 ask for, and the Vulkan tests, in one short run on a
# device machine, from the archive bench/gpu/bundle.sh made (BUNDLE, default gpu-bundle):
#   - fast and final frames of the Cornell box at 640x480 and 1920x1080, twice each (the
#     second with the shader cache warm), every stage row printed: frame wall against the
#     GPU's busy time; then 4 frames of an animated scene at the larger size, each;
#   - the BIH of 1M triangles: build (tree read back, nodes kept) and refit, wall and GPU;
#   - 1M photons traced and gridded (photon_bench, the repository's scenes);
#   - the LPV propagation where each site runs it (lpv_bench sites);
#   - every test ctest runs on a Vulkan device, with the validation layer, as ctest sets
#     them up (TESTS: a space-separated subset; "none" skips them).
# The figures go to stdout and $OUT/figures.log, the tests' output to $OUT/tests.log
# ($OUT: the device tool's folder; else /tmp/device-check). SCALE=quick runs small
# sizes, to check the script on lavapipe.
set -u
bundle=${1:-gpu-bundle}
out=${OUT:-/tmp/device-check}
mkdir -p "$out"
root=$(mktemp -d)
xz -dc "$bundle/bundle.tar.xz" | tar -C "$root" -xf - || exit 2
# The GL dispatch libraries the NVIDIA ICD loads (bundle.sh says why), into / as the
# device tool's notes advise; the machine is bare and given back after the lease.
if [ -d "$bundle/gl" ] && [ "$(id -u)" = 0 ] && command -v nvidia-smi > /dev/null; then
    for package in "$bundle"/gl/*.deb; do dpkg -x "$package" /; done
    ldconfig
fi
export LD_LIBRARY_PATH="$root/lib${LD_LIBRARY_PATH:+:$LD_LIBRARY_PATH}"
export VK_LAYER_PATH="$root/layers"
# The NVIDIA driver's ICD, where one is installed (the loader finds the others itself).
for icd in /usr/share/vulkan/icd.d/nvidia_icd*.json /etc/vulkan/icd.d/nvidia_icd*.json \
    /usr/local/nvidia/share/vulkan/icd.d/nvidia_icd*.json; do
    if [ -f "$icd" ]; then
        export VK_DRIVER_FILES="$icd"
        break
    fi
done
bin=$root/bin
if ! "$bin/photonfarm" devices > "$out/figures.log" 2>&1; then
    cat "$out/figures.log"
    echo "device_check.sh: no Vulkan device: nothing run (the driver's ICD: VK_DRIVER_FILES)"
    exit 2
fi
triangles=1000000 photons=1000000 sizes="640x480 1920x1080" limit=150
if [ "${SCALE:-}" = quick ]; then
    triangles=20000 photons=20000 sizes="160x120" limit=300
fi
step() {
    echo "== $*"
    timeout "$limit" "$@" 2>&1
    echo "(exit $?)"
}
{
    date -u
    nvidia-smi --query-gpu=name,driver_version,memory.total --format=csv 2>&1
    cat "$out/figures.log"
    for quality in fast final; do
        for size in $sizes; do
            for round in 1 2; do
                step "$bin/photonfarm" render scenes/cornell/cornell.gltf --frame 1 \
                    --quality "$quality" --size "$size" --timings \
                    --cache-dir "$root/cache" -o "$root/$quality-$size-$round.exr"
            done
        done
    done
    # A sequence: frame n's EXR is written while frame n+1 renders (exr_write behind=1).
    for quality in fast final; do
        step "$bin/photonfarm" render scenes/cornell-moving/cornell-moving.gltf --frames 1-4 \
            --quality "$quality" --size "${sizes##* }" --timings --cache-dir "$root/cache" \
            -o "$root/sequence-$quality-####.exr"
    done
    step "$bin/bih_refit_bench" "$triangles"
    step "$bin/photon_bench" "$photons" scenes
    step "$bin/photon_bench" "$photons" "$root/shared-scenes"
    step "$bin/lpv_bench" sites
} | tee "$out/figures.log.new"
mv "$out/figures.log.new" "$out/figures.log"
tests=${TESTS:-$(sed 's|.*/||' "$root/tests.list" | grep -v -E \
    '^(test_worker_|test_storage_roots$|test_settings_codec$|image_exr_layout$)')}
[ "$tests" = none ] && exit 0
# One test as ctest runs it (tests/CMakeLists.txt, pf_add_test), its output kept.
run_test() {
    local name=$1
    local tmp=$root/test-tmp/$name
    mkdir -p "$tmp"
    local start=$SECONDS
    PF_SHARED_SCENES=$root/shared-scenes PF_SOURCE_DIR=$PWD PF_TEST_TMP=$tmp \
        PHOTONFARM=$bin/photonfarm PF_VK_VALIDATION=1 \
        timeout 240 "$root/tests/$name" > "$root/test-tmp/$name.log" 2>&1
    echo "$? $((SECONDS - start)) $name" > "$root/test-tmp/$name.result"
}
export -f run_test
export root bin
mkdir -p "$root/test-tmp"
printf '%s\n' $tests | xargs -P "${JOBS:-6}" -I{} bash -c 'run_test {}'
{
    for name in $tests; do
        echo "=== $name: $(cat "$root/test-tmp/$name.result")"
        cat "$root/test-tmp/$name.log"
    done
} > "$out/tests.log"
failed=0 passed=0
for name in $tests; do
    read -r status seconds _ < "$root/test-tmp/$name.result"
    if [ "$status" = 0 ]; then
        passed=$((passed + 1))
    else
        failed=$((failed + 1))
        echo "FAILED ($status, ${seconds}s): $name"
        grep -E 'FAIL|error|Validation' "$root/test-tmp/$name.log" | head -5
    fi
done
echo "tests on the device: $passed passed, $failed failed"
