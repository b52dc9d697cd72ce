#!/bin/sh
# Packs what bench/gpu/device_check.sh runs on a device machine, which has a GPU and its
# driver but neither this project's build nor Debian's libraries: the binaries of BUILD
# (default build), their debug sections stripped, and every shared library they link
# but glibc's own (the device machine's glibc is as new or newer). The bundle goes to OUT
# (default gpu-bundle, which git ignores); the device tool carries it: run with
# carry ["gpu-bundle"] and the command `bench/gpu/device_check.sh`.
set -eu
build=${1:-build}
out=${2:-gpu-bundle}
rm -rf "$out"
mkdir -p "$out/bin" "$out/lib"
for binary in worker/photonfarm bench/bih/bih_refit_bench bench/photon/photon_bench \
    bench/lpv/lpv_bench; do
    if [ ! -x "$build/$binary" ]; then
        echo "bundle.sh: $build/$binary is missing: build first (./bootstrap.sh build)" >&2
        exit 2
    fi
    objcopy --strip-debug "$build/$binary" "$out/bin/$(basename "$binary")"
done
for binary in "$out"/bin/*; do ldd "$binary"; done | awk '/=> \// {print $3}' | sort -u |
    while read -r library; do
        case "$(basename "$library")" in
        libc.so.* | libm.so.* | libpthread.so.* | libdl.so.* | librt.so.* | ld-linux*) ;;
        *) cp -L "$library" "$out/lib/" ;;
        esac
    done
du -sh "$out"
