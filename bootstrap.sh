#!/usr/bin/env bash
# photonfarm bootstrap for Debian 12 (bookworm).
#
#   ./bootstrap.sh deps    install the Debian packages the build needs (no-op when present)
#   ./bootstrap.sh build   deps, then a warnings-as-errors RelWithDebInfo build in build/
#   ./bootstrap.sh test    deps, then build and run the whole suite plain (build/) and
#                          under ASan+UBSan (build-asan/), compile the Release configuration
#                          (build-release/, -Werror at -O3); ends with "N passed, M failed"
#   ./bootstrap.sh demo    deps, build, then enqueue the bundled animated demo into an embedded
#                          SQLite queue (demo-out/farm.db), run a worker until the job is done,
#                          and print the job's stage timings
#   ./bootstrap.sh quality [WxH]
#                          deps + Blender, build, then the speed-against-error report
#                          (bench/quality) on the shared scenes against Cycles: CSV and
#                          SVG per scene in bench-out/quality/ (default 160x160)
#
# Works from any directory: every path is relative to this script's directory.
# PF_JOBS sets the build parallelism (default: all CPUs).
set -euo pipefail

ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
cd "$ROOT"

# Debian package -> why (README.md "Dependencies" explains each one).
PACKAGES=(
  build-essential         # gcc 12, make, libc headers (and g++ for the Embree peer in bench/)
  cmake                   # build system (3.25 in bookworm)
  ninja-build             # build backend
  pkg-config              # finds OpenEXR, cJSON, libuv, SQLite
  libvulkan-dev           # Vulkan loader + headers
  mesa-vulkan-drivers     # lavapipe: the CPU Vulkan device when there is no GPU
  vulkan-validationlayers # tests run with validation on
  glslang-tools           # glslangValidator: GLSL -> SPIR-V at build time
  spirv-tools             # spirv-opt optimises, spirv-val checks every shader at build time
  libopenexr-dev          # EXR output and the reader behind `compare`
  openexr                 # exrheader: tests read every output layout with OpenEXR's own tools
  libuv1-dev              # worker event loop
  libsqlite3-dev          # the job queue
  libpq-dev               # the job queue on PostgreSQL (farms spanning hosts)
  libmicrohttpd-dev       # photonfarm serve: the monitor's HTTP server
  postgresql              # tests: the queue tests also run on a throwaway cluster
  python3-yaml            # tests: the Kubernetes manifests are parsed and checked
  chromium                # tests: the monitor's page is checked in a real (headless) browser
  libcjson-dev            # glTF JSON parsing
  libspng-dev             # texture images: PNG
  libturbojpeg0-dev       # texture images: JPEG
  libwebp-dev             # texture images: WebP (EXT_texture_webp)
  libdraco-dev            # glTF meshes compressed with Draco (KHR_draco_mesh_compression)
  draco                   # tests: draco_transcoder compresses the glTF the tests decode
  libmeshoptimizer-dev    # glTF buffers compressed by meshoptimizer (EXT_meshopt_compression)
  gltfpack                # tests: gltfpack compresses the glTF the tests decode
  libembree-dev           # bench/: CPU ray-casting peer for speed comparisons
)

# Only for `quality`: Cycles, the peer of bench/quality, and the numpy its glTF importer needs.
QUALITY_PACKAGES=(blender python3-numpy)

JOBS=${PF_JOBS:-$(nproc)}
# ctest parallelism: the suite is sized for 2 cores (CI), and lavapipe tests each use
# several threads already; one test more than cores, because the worker tests spend much
# of their time waiting (leases, signals, the writer), which a third test fills (the plain
# suite 195 → 172 s on the 2-core VM).
TEST_JOBS=3

DEMO_SCENE=scenes/cornell-moving/cornell-moving.gltf
DEMO_FRAMES=1-24
DEMO_SIZE=320x240
DEMO_OUTPUT=demo-out/frame.####.exr
DEMO_DB=demo-out/farm.db

usage() {
  sed -n '2,18s/^# \{0,1\}//p' "$0" >&2
  exit 2
}

as_root() {
  if [ "$(id -u)" -eq 0 ]; then
    "$@"
  else
    sudo "$@"
  fi
}

cmd_deps() {
  install_packages "${PACKAGES[@]}"
}

install_packages() {
  local missing=() package
  for package in "$@"; do
    if [ "$(dpkg-query -W -f='${Status}' "$package" 2>/dev/null)" != "install ok installed" ]; then
      missing+=("$package")
    fi
  done
  if [ "${#missing[@]}" -eq 0 ]; then
    echo "bootstrap: all $# Debian packages present"
    return 0
  fi
  echo "bootstrap: installing ${missing[*]}"
  as_root env DEBIAN_FRONTEND=noninteractive apt-get update -q
  as_root env DEBIAN_FRONTEND=noninteractive \
    apt-get install -y -q --no-install-recommends "${missing[@]}"
}

# configure_and_build DIR [CMAKE_ARGS...]
configure_and_build() {
  local dir=$1
  shift
  # One shader cache for every build directory: spirv-opt's modules do not depend on the C
  # flags, so the ASan and Release builds copy what the first build optimised.
  cmake -S "$ROOT" -B "$ROOT/$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo \
    -DPF_WERROR=ON -DPF_SHADER_CACHE_DIR="$ROOT/build/shader-cache" "$@"
  cmake --build "$ROOT/$dir" -j "$JOBS"
}

cmd_build() {
  cmd_deps
  configure_and_build build
}

PASSED=0
FAILED=0

# run_suite DIR [CMAKE_ARGS...]: builds DIR and runs its ctest suite, adding to
# PASSED/FAILED. A build failure counts as one failure (its tests cannot run).
run_suite() {
  local dir=$1 log total failed start=$SECONDS
  shift
  echo "bootstrap: === $dir ==="
  if ! configure_and_build "$dir" "$@"; then
    echo "bootstrap: $dir: build failed"
    FAILED=$((FAILED + 1))
    return 0
  fi
  # Each phase's seconds, so that the suite's time (the brief: under 12 minutes on 2 cores)
  # can be watched where it goes.
  echo "bootstrap: $dir: built in $((SECONDS - start)) s"
  start=$SECONDS
  log="$ROOT/$dir/ctest-summary.log"
  ctest --test-dir "$ROOT/$dir" --output-on-failure -j "$TEST_JOBS" 2>&1 | tee "$log" || true
  echo "bootstrap: $dir: tests ran in $((SECONDS - start)) s"
  # ctest's closing line: "NN% tests passed, F tests failed out of T"
  if read -r failed total < <(sed -n \
      's/^[0-9]*% tests passed, \([0-9]*\) tests\{0,1\} failed out of \([0-9]*\)$/\1 \2/p' "$log"); then
    PASSED=$((PASSED + total - failed))
    FAILED=$((FAILED + failed))
  else
    echo "bootstrap: $dir: ctest produced no summary (no tests, or it crashed)"
    FAILED=$((FAILED + 1))
  fi
}

cmd_test() {
  cmd_deps
  if [ ! -d "$ROOT/../shared/scenes" ]; then
    echo "bootstrap: $(cd "$ROOT/.." && pwd)/shared/scenes is missing: the tests that render" \
      "the shared scenes are skipped (listed as not run)"
  fi
  run_suite build
  run_suite build-asan -DPF_SANITIZE=ON
  # A warning that only -O3 shows (issue 17) must not land: compile Release too.
  echo "bootstrap: === build-release (compile only) ==="
  local start=$SECONDS
  if ! configure_and_build build-release -DCMAKE_BUILD_TYPE=Release; then
    echo "bootstrap: build-release: build failed"
    FAILED=$((FAILED + 1))
  fi
  echo "bootstrap: build-release: built in $((SECONDS - start)) s; the whole run $SECONDS s"
  echo "$PASSED passed, $FAILED failed"
  [ "$FAILED" -eq 0 ]
}

cmd_demo() {
  cmd_build
  local photonfarm="$ROOT/build/worker/photonfarm" job
  mkdir -p "$ROOT/demo-out"
  job=$("$photonfarm" enqueue "$DEMO_SCENE" --frames "$DEMO_FRAMES" --size "$DEMO_SIZE" \
    --out "$DEMO_OUTPUT" --name cornell-demo --db "$DEMO_DB")
  "$photonfarm" worker --once --db "$DEMO_DB"
  "$photonfarm" status "$job" --db "$DEMO_DB"
  "$photonfarm" timings "$job" --db "$DEMO_DB"
  echo "bootstrap: demo job $job: frames in $ROOT/demo-out/, queue in $ROOT/$DEMO_DB"
}

# One report per shared scene; the image sizes keep each scene's camera aspect
# (Cycles and photonfarm must frame it alike). Threads: 2 for both renderers.
QUALITY_SCENES=(cornell-box:1 caustic-anim:1.7777777778 staircase2:1)

cmd_quality() {
  local size=${1:-160x160} width height entry name aspect out
  case "$size" in
    [0-9]*x[0-9]*) width=${size%x*} ;;
    *) echo "bootstrap: quality: size '$size': expected WxH" >&2; exit 2 ;;
  esac
  cmd_build
  install_packages "${QUALITY_PACKAGES[@]}"
  out="$ROOT/bench-out/quality"
  mkdir -p "$out"
  for entry in "${QUALITY_SCENES[@]}"; do
    name=${entry%%:*}
    aspect=${entry#*:}
    height=$(awk -v w="$width" -v a="$aspect" 'BEGIN { printf "%d", w / a + 0.5 }')
    if [ ! -f "$ROOT/../shared/scenes/$name/$name.gltf" ]; then
      echo "bootstrap: quality: ../shared/scenes/$name missing, skipped"
      continue
    fi
    LP_NUM_THREADS=2 PF_SOURCE_DIR="$ROOT" "$ROOT/build/bench/quality/quality_bench" \
      "$ROOT/../shared/scenes/$name/$name.gltf" "$width" "$height" "$out/$name" \
      "$(command -v blender)" 2
  done
}

case "${1:-}" in
  deps) [ $# -eq 1 ] || usage; cmd_deps ;;
  build) [ $# -eq 1 ] || usage; cmd_build ;;
  test) [ $# -eq 1 ] || usage; cmd_test ;;
  demo) [ $# -eq 1 ] || usage; cmd_demo ;;
  quality) [ $# -le 2 ] || usage; cmd_quality "${2:-}" ;;
  *) usage ;;
esac
