#!/usr/bin/env bash
# A worker's throughput with frames written behind the render (issue 43), against a build
# that wrote each frame before rendering the next: the same job (the bundled animated
# Cornell box, one frame a task) is enqueued into a fresh SQLite queue for each build
# and one `worker --once` renders it. Rounds alternate the builds; prints the wall
# seconds of each run and the job's summed exr_write and shade wall times.
#
#   bench/worker/write_behind.sh NEW OLD [QUALITY] [SIZE] [FRAMES] [ROUNDS]
#
# NEW, OLD: photonfarm binaries (OLD, e.g., built from a worktree of an earlier commit).
# Defaults: preview, 1920x1080, 1-8, 2 rounds. One heavy job at a time.
set -euo pipefail
ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)
NEW=$1
OLD=$2
QUALITY=${3:-preview}
SIZE=${4:-1920x1080}
FRAMES=${5:-1-8}
ROUNDS=${6:-2}
SCENE=$ROOT/scenes/cornell-moving/cornell-moving.gltf
WORK=$(mktemp -d)
trap 'rm -rf "$WORK"' EXIT

run() { # label, binary
  local dir=$WORK/$1 start end
  rm -rf "$dir"
  mkdir -p "$dir"
  "$2" enqueue "$SCENE" --frames "$FRAMES" --out "$dir/f.####.exr" --size "$SIZE" \
    --quality "$QUALITY" --db "$dir/q.db" >/dev/null 2>&1
  start=$(date +%s.%N)
  "$2" worker --once --db "$dir/q.db" >"$dir/log" 2>&1
  end=$(date +%s.%N)
  local sums # the job's summed wall times, from its own timings (column 8: wall_total_ms)
  sums=$("$2" timings 1 --format csv --db "$dir/q.db" 2>/dev/null |
    awk -F, '$1 == "exr_write" { w = $8 } $1 == "shade" { s = $8 }
             END { printf "exr_write %.0f ms, shade %.0f ms", w, s }')
  awk -v a="$start" -v b="$end" -v l="$1" -v s="$sums" -v n="$(ls "$dir"/*.exr | wc -l)" \
    'BEGIN { printf "%-4s %7.2f s  %d frames  (%s)\n", l, b - a, n, s }'
}

echo "worker --once, $QUALITY $SIZE frames $FRAMES, one frame a task"
echo "device: $("$NEW" devices 2>/dev/null | sed -n 1p)"
for round in $(seq "$ROUNDS"); do
  run old "$OLD"
  run new "$NEW"
done
