#!/usr/bin/env bash
# Time to first frame of a new photonfarm process, with an empty shader cache
# (cold: every pipeline compiles) and with the cache the first run left (warm:
# the second process on a machine). Prints seconds and the warm/cold ratio.
#
#   bench/startup/cold_start.sh [PHOTONFARM] [QUALITY] [SIZE]
#
# Defaults: build/worker/photonfarm, final, 640x480, the bundled Cornell scene.
# One heavy job at a time: the figures are wall-clock seconds on this machine.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
PHOTONFARM=${1:-$ROOT/build/worker/photonfarm}
QUALITY=${2:-final}
SIZE=${3:-640x480}
SCENE=$ROOT/scenes/cornell-moving/cornell-moving.gltf
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

run() { # label, cache dir -> prints "label seconds"
  local start end
  start=$(date +%s.%N)
  # Mesa's own cache setting would bypass the directory under test.
  env -u MESA_SHADER_CACHE_DIR "$PHOTONFARM" render "$SCENE" --frame 1 --size "$SIZE" \
    --quality "$QUALITY" --cache-dir "$2" -o "$WORK/frame.####.exr" >/dev/null 2>&1
  end=$(date +%s.%N)
  awk -v a="$start" -v b="$end" -v l="$1" 'BEGIN { printf "%s %.3f\n", l, b - a }'
}

echo "photonfarm cold start: render --frame 1 --quality $QUALITY --size $SIZE"
echo "device: $("$PHOTONFARM" devices 2>/dev/null | sed -n 1p)"
cold=$(run cold "$WORK/cache" | cut -d' ' -f2)
warm=$(run warm "$WORK/cache" | cut -d' ' -f2)
printf "cold (empty cache)      %7.2f s\n" "$cold"
printf "warm (second process)   %7.2f s\n" "$warm"
awk -v w="$warm" -v c="$cold" 'BEGIN { printf "warm / cold             %7.3f\n", w / c }'
printf "cache directory         %s\n" "$(du -sh "$WORK/cache" | cut -f1)"
