#!/usr/bin/env bash
# A two-worker farm in containers, for real (issue 13, item 5): builds the
# worker image with podman, enqueues the bundled animated demo into a SQLite
# queue on a bind-mounted host directory, starts two worker containers, kills
# one with SIGKILL while it holds a frame, and asserts that the job finishes
# anyway: every frame done once, every EXR readable, a timing row per frame,
# the killed worker's lease expired and its frame rendered by the other.
#
#   ../shared/tools/podman-setup.sh        # once per machine (makes pf-podman)
#   tests/container/farm_test.sh           # ~5 min with a cached image build
#   tests/container/farm_test.sh --postgres
#       the same farm on a PostgreSQL queue: a throwaway cluster on the host's
#       loopback (tests/jobs/pg_throwaway.sh), the containers on the host's
#       network with PHOTONFARM_DB=postgresql://...
#
# Then the monitor (issue 41) the way compose.yaml's `monitor` service runs it: `serve` on
# every address with an action token from a secret file, its healthcheck command run
# inside the container, and its API read from the host: the finished job, a frame's log
# as w2 stored it, an action refused without the token and done with it.
#
# Not part of ctest: an image build takes minutes more than CI's budget.
# Exit status 0 when every check holds, 1 otherwise.
set -euo pipefail

ROOT=$(cd "$(dirname "$0")/../.." && pwd)
PODMAN=${PODMAN:-pf-podman}
IMAGE=photonfarm-farm-test
FRAMES=12
WORK=$(mktemp -d /tmp/photonfarm-farm.XXXXXX)
DATA=$WORK/data
failures=0
POSTGRES=0
[ "${1:-}" = --postgres ] && POSTGRES=1
DB_ARGS=()

check() { # check DESCRIPTION COMMAND...: runs it, counts a failure
  local what=$1
  shift
  if "$@"; then echo "ok   $what"; else echo "FAIL $what"; failures=$((failures + 1)); fi
}

cleanup() {
  $PODMAN rm -f pf-farm-w1 pf-farm-w2 pf-farm-monitor >/dev/null 2>&1 || true
  [ "$POSTGRES" -eq 0 ] || "$ROOT/tests/jobs/pg_throwaway.sh" stop "$WORK/pg"
  rm -rf "$WORK"
}
trap cleanup EXIT

# The image's user (uid 10001) writes the queue and the frames.
mkdir -p "$DATA"
chown 10001:10001 "$DATA" 2>/dev/null || chmod 0777 "$DATA"

if [ "$POSTGRES" -eq 1 ]; then
  chmod 755 "$WORK"
  url=$("$ROOT/tests/jobs/pg_throwaway.sh" start "$WORK/pg" 55499)
  # pf-podman runs every container on the host network already (the loopback is shared).
  DB_ARGS=(-e "PHOTONFARM_DB=$url")
  echo "farm_test: queue on $url"
fi

echo "farm_test: building $IMAGE"
$PODMAN build --format docker -q -t "$IMAGE" \
  --build-arg PF_GIT_REVISION="$(git -C "$ROOT" rev-parse --short=12 HEAD 2>/dev/null || echo unknown)" \
  -f "$ROOT/docker/Dockerfile" "$ROOT" >/dev/null

photonfarm() { # photonfarm ARGS...: a one-shot container on the same data
  $PODMAN run --rm "${DB_ARGS[@]}" -v "$DATA:/data" "$IMAGE" "$@"
}

photonfarm enqueue /opt/photonfarm/scenes/cornell-moving/cornell-moving.gltf \
  --frames "1-$FRAMES" --size 160x120 --quality fast --out /data/frame.####.exr --name farm-test

# Short leases, so that the killed worker's frame comes back within seconds.
for n in 1 2; do
  $PODMAN run -d --name "pf-farm-w$n" "${DB_ARGS[@]}" -e PHOTONFARM_WORKER_NAME="w$n" \
    -v "$DATA:/data" \
    "$IMAGE" worker --lease-seconds 6 --idle-exit 20 >/dev/null
done

# Wait until w1 holds a frame, then kill it (SIGKILL: no drain, no release).
holding=1
for _ in $(seq 1 300); do
  if photonfarm status 1 2>/dev/null | grep -q "running: frame .* on w1 "; then
    holding=0
    break
  fi
  sleep 0.2
done
check "w1 was rendering a frame when it was killed" test "$holding" -eq 0
$PODMAN kill --signal KILL pf-farm-w1 >/dev/null

# The job finishes on w2 alone.
for _ in $(seq 1 300); do
  if photonfarm status 1 2>/dev/null | grep -q "done "; then break; fi
  sleep 1
done
status=$(photonfarm status 1)
echo "$status"
check "the job is done, $FRAMES/$FRAMES frames" grep -q "$FRAMES/$FRAMES" <<<"$status"
check "w1's lease expired and was recorded" grep -q "lease expired (worker w1" <<<"$status"
check "w2 is alive by the HEALTHCHECK's command" photonfarm workers --check w2

# Every frame once: an EXR that reads back, one shade row per frame.
reads_back() { photonfarm compare "$1" "$1" --format json >/dev/null; }
for f in $(seq -f "%04g" 1 "$FRAMES"); do
  check "frame $f reads back" reads_back "/data/frame.$f.exr"
done
timings=$(photonfarm timings 1 --format csv)
check "one shade row per frame" grep -q "^shade,$FRAMES," <<<"$timings"
check "no partial file left" \
  bash -c "! ls '$DATA' | grep -q partial"

$PODMAN stop -t 30 pf-farm-w2 >/dev/null 2>&1 || true

# The monitor, as compose.yaml's `monitor` service: every address, a token file.
MONITOR_PORT=$(python3 -c 'import socket; s = socket.socket(); s.bind(("127.0.0.1", 0)); print(s.getsockname()[1])')
head -c 24 /dev/urandom | base64 > "$WORK/monitor-token"
chmod 644 "$WORK/monitor-token"
$PODMAN run -d --name pf-farm-monitor "${DB_ARGS[@]}" -v "$DATA:/data" \
  -v "$WORK/monitor-token:/run/secrets/monitor-token:ro" \
  "$IMAGE" serve --listen "0.0.0.0:$MONITOR_PORT" --token-file /run/secrets/monitor-token >/dev/null
healthy() { # compose.yaml's healthcheck command, inside the container
  $PODMAN exec pf-farm-monitor bash -c "exec 3<>/dev/tcp/127.0.0.1/$MONITOR_PORT && printf 'GET /healthz HTTP/1.0\r\n\r\n' >&3 && grep -q '^ok' <&3"
}
for _ in $(seq 1 50); do healthy 2>/dev/null && break; sleep 0.2; done
check "the monitor's healthcheck passes" healthy
monitor_api() { # monitor_api METHOD PATH [TOKEN]: prints "CODE BODY"
  python3 - "$MONITOR_PORT" "$@" <<'PY'
import sys, urllib.request, urllib.error
port, method, path = sys.argv[1], sys.argv[2], sys.argv[3]
request = urllib.request.Request("http://127.0.0.1:%s%s" % (port, path), method=method)
if len(sys.argv) > 4:
    request.add_header("X-Photonfarm-Token", sys.argv[4])
try:
    with urllib.request.urlopen(request, timeout=10) as response:
        print(response.status, response.read().decode())
except urllib.error.HTTPError as error:
    print(error.code, error.read().decode())
PY
}
jobs=$(monitor_api GET /api/jobs)
check "the monitor lists the job, done, $FRAMES/$FRAMES" \
  python3 -c "import json, sys; code, body = sys.argv[1].split(' ', 1); job = json.loads(body)[0]; \
sys.exit(not (code == '200' and job['status'] == 'done' and job['frames_done'] == $FRAMES))" "$jobs"
log=$(monitor_api GET "/api/jobs/1/frames/$FRAMES/log")
check "frame $FRAMES's log, as w2 stored it" \
  python3 -c "import json, sys; code, body = sys.argv[1].split(' ', 1); a = json.loads(body)['attempts']; \
sys.exit(not (code == '200' and any(x['worker'] == 'w2' and 'event=rendered' in x['log'] for x in a)))" "$log"
check "an action without the token is refused" grep -q '^403 ' <<<"$(monitor_api POST /api/jobs/1/priority?value=5)"
check "an action with the token is done" \
  grep -q '^200 ' <<<"$(monitor_api POST /api/jobs/1/priority?value=5 "$(cat "$WORK/monitor-token")")"
check "the priority was set" grep -q '"priority":5' <<<"$(monitor_api GET /api/jobs)"
$PODMAN stop -t 10 pf-farm-monitor >/dev/null 2>&1 || true
echo "farm_test: $failures failure(s)"
[ "$failures" -eq 0 ]
