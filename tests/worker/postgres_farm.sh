#!/usr/bin/env bash
# A farm on PostgreSQL (issue 13), run by tests/jobs/with_postgres.sh: three
# worker processes render a 6-frame job; two are SIGKILLed while they hold a
# frame, the database server is restarted, two workers are started again.
# Checked: every frame done once, each EXR present with no temporary left,
# one set of stage rows per frame, the dead workers' leases recorded as
# expired, the surviving workers reconnected and exited 0; and a URL that
# cannot be used exits 2 without printing its password.
set -u
# photonfarm, with what it needs preloaded under ASan ($PF_PRELOAD; never psql or PostgreSQL).
pf() { LD_PRELOAD="${PF_PRELOAD:-}" "$PHOTONFARM" "$@"; }
url=$PF_TEST_POSTGRES_URL
dir=$PF_TEST_TMP/farm
rm -rf "$dir"
mkdir -p "$dir/out"
failed=0
check() {
  if eval "$2"; then echo "ok   $1"; else echo "FAIL $1"; failed=1; fi
}

pf enqueue "$PF_SOURCE_DIR/scenes/cornell-moving/cornell-moving.gltf" --frames 1-6 --size 32x24 \
  --quality fast -o "$dir/out/f.####.exr" --db "$url" > /dev/null || exit 1

# fault_inject.c holds each finished frame 3 s before its rename: a worker
# killed after it claimed is provably mid-frame.
export PF_FAULT_DIR="$dir/out" PF_FAULT_HOLD_MS=3000
export ASAN_OPTIONS="${ASAN_OPTIONS:+$ASAN_OPTIONS:}verify_asan_link_order=0"
preload="${PF_PRELOAD:+$PF_PRELOAD }$PF_FAULT_INJECT_LIB"
start_worker() {
  LD_PRELOAD=$preload "$PHOTONFARM" worker --db "$url" --name "$1" --lease-seconds 3 --idle-exit 8 \
    --cache-dir "$dir/cache" 2> "$dir/$1.log" &
}
start_worker w1; w1=$!
start_worker w2; w2=$!
start_worker w3; w3=$!

claimed() { grep -q "event=claimed" "$dir/$1.log" 2>/dev/null; }
for _ in $(seq 600); do
  claimed w1 && claimed w2 && break
  sleep 0.5
done
check "w1 and w2 claimed a frame" "claimed w1 && claimed w2"
kill -9 "$w1" "$w2"
wait "$w1" "$w2" 2>/dev/null

"$(dirname "$0")/../jobs/pg_throwaway.sh" restart "$PF_TEST_POSTGRES_DIR"
start_worker w4; w4=$!
start_worker w5; w5=$!
for pid in $w3 $w4 $w5; do
  wait "$pid"
  check "worker $pid exited 0 after the restart" "[ $? -eq 0 ]"
done

status=$(pf status 1 --db "$url")
check "job done, 6/6 frames" "grep -q '6/6' <<< \"\$status\" && grep -q ' done ' <<< \"\$status\""
check "6 EXRs" "[ \$(ls \"$dir\"/out/f.000[1-6].exr 2>/dev/null | wc -l) -eq 6 ]"
check "no temporary left" "[ -z \"\$(ls \"$dir\"/out | grep partial)\" ]"
count() { psql -At "$url" -c "$1"; }
check "one shade row per frame" \
  "[ \"\$(count \"SELECT count(*), count(DISTINCT frame) FROM stage_timings WHERE stage = 'shade'\")\" = '6|6' ]"
check "w1 and w2's leases expired" \
  "[ \"\$(count \"SELECT count(DISTINCT worker_name) FROM task_failures WHERE worker_name IN ('w1','w2') AND error LIKE '%lease expired%'\")\" = 2 ]"
check "every task done with one completion" \
  "[ \"\$(count \"SELECT count(*) FROM tasks WHERE status = 'done' AND finished_at IS NOT NULL\")\" = 6 ]"

bad=$(pf status --db "postgresql://someone:s3cret-pw@127.0.0.1:1/photonfarm" 2>&1)
code=$?
check "unreachable server: exit 2" "[ $code -eq 2 ]"
check "the message names the cause, not the password" \
  "grep -q 'cannot connect' <<< \"\$bad\" && ! grep -q s3cret <<< \"\$bad\""
echo "$bad"
exit $failed
