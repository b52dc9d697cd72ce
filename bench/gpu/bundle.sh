#!/bin/sh
# Packs what bench/gpu/device_check.sh runs on a device machine, which has a GPU and its
# driver but neither this project's build nor Debian's libraries: the binaries of BUILD
# (default build), their debug sections stripped, and every shared library they link
# but glibc's own (the device machine's glibc is as new or newer). With them go the
# tests that run on a Vulkan device (those ctest gives PF_VK_VALIDATION=1), the Khronos
# validation layer they enable, and the shared scenes they read (../shared does not
# travel), all in one archive, OUT/bundle.tar.xz, and the GL dispatch packages the NVIDIA
# driver needs (OUT/gl). OUT (default gpu-bundle) is ignored by git; the device tool
# carries it: run with carry ["gpu-bundle"] and the command `bench/gpu/device_check.sh`.
set -eu
build=${1:-build}
out=${2:-gpu-bundle}
shared_scenes=${PF_SHARED_SCENES:-$(dirname "$0")/../../../shared/scenes}
final=$out
out=$(mktemp -d)
rm -rf "$final"
mkdir -p "$final"
mkdir -p "$out/bin" "$out/lib" "$out/tests" "$out/layers"
for binary in worker/photonfarm bench/bih/bih_refit_bench bench/photon/photon_bench \
    bench/lpv/lpv_bench; do
    if [ ! -x "$build/$binary" ]; then
        echo "bundle.sh: $build/$binary is missing: build first (./bootstrap.sh build)" >&2
        exit 2
    fi
    objcopy --strip-debug "$build/$binary" "$out/bin/$(basename "$binary")"
done
# The Vulkan tests, named as ctest runs them.
(cd "$build" && ctest -N -V) | awk '
    /Test command:/ { command = $NF }
    /Environment variables/ { environment = 1; next }
    environment && /PF_VK_VALIDATION=1/ { print command }
    /^ *[0-9]+: Test #/ { environment = 0 }' | sort -u > "$out/tests.list"
while read -r test; do
    objcopy --strip-debug "$test" "$out/tests/$(basename "$test")"
done < "$out/tests.list"
layer_json=/usr/share/vulkan/explicit_layer.d/VkLayer_khronos_validation.json
layer=$(sed -n 's/.*"library_path": *"\([^"]*\)".*/\1/p' "$layer_json")
layer_path=$(ldconfig -p | awk -v name="$(basename "$layer")" '$1 == name {print $NF; exit}')
cp "$layer_json" "$out/layers/"
objcopy --strip-debug "$layer_path" "$out/lib/$(basename "$layer")"
if [ -d "$shared_scenes" ]; then
    cp -r "$shared_scenes" "$out/shared-scenes"
else
    echo "bundle.sh: no shared scenes at $shared_scenes: tests that read them will skip" >&2
fi
for binary in "$out"/bin/* "$out"/tests/* "$out/lib/$(basename "$layer")"; do
    ldd "$binary"
done | awk '/=> \// {print $3}' | sort -u |
    while read -r library; do
        case "$(basename "$library")" in
        libc.so.* | libm.so.* | libpthread.so.* | libdl.so.* | librt.so.* | ld-linux*) ;;
        *) [ -e "$out/lib/$(basename "$library")" ] || cp -L "$library" "$out/lib/" ;;
        esac
    done
# The device machine's image has the NVIDIA driver but not the GL vendor-neutral
# dispatch libraries its Vulkan ICD (libGLX_nvidia) loads: without them the loader finds
# no driver. Debian's packages, unpacked there by device_check.sh.
mkdir -p "$final/gl"
lists=$(mktemp -d)
mkdir -p "$lists/partial"
apt_options="-oAPT::Architecture=amd64 -oAPT::Architectures=amd64 -oDir::State::Lists=$lists"
# shellcheck disable=SC2086
if apt-get $apt_options update > /dev/null 2>&1; then
    # shellcheck disable=SC2086
    (cd "$final/gl" && apt-get $apt_options download libglvnd0 libgl1 libglx0 libegl1 \
        libgles2 libopengl0 > /dev/null 2>&1) ||
        echo "bundle.sh: could not download the GL dispatch packages" >&2
else
    echo "bundle.sh: apt-get update failed: the bundle has no GL dispatch packages" >&2
fi
rm -rf "$lists"
# One compressed archive: the binaries each embed their SPIR-V, and the carry is 64 MiB.
tar -C "$out" -cf - . | xz -T0 > "$final/bundle.tar.xz"
rm -rf "$out"
du -sh "$final"
