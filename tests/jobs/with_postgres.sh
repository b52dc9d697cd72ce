#!/usr/bin/env bash
# Runs a queue test binary against a throwaway PostgreSQL cluster (issue 13):
#   with_postgres.sh TEST_BINARY [ARGS...]
# The cluster (pg_throwaway.sh) listens on a free loopback port, lives in a
# temporary directory and is removed afterwards, whatever the test's outcome.
set -euo pipefail
here=$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)
dir=$(mktemp -d /tmp/pf-pg.XXXXXX)
chmod 755 "$dir"
trap '"$here/pg_throwaway.sh" stop "$dir/cluster"; rm -rf "$dir"' EXIT

# A port nobody listens on: start from one derived from our pid.
port=$((20000 + $$ % 20000))
while (exec 3<>"/dev/tcp/127.0.0.1/$port") 2>/dev/null; do
  port=$((port + 1))
done
PF_TEST_POSTGRES_URL=$("$here/pg_throwaway.sh" start "$dir/cluster" "$port")
export PF_TEST_POSTGRES_URL
# For tests that restart the server (pg_throwaway.sh restart "$PF_TEST_POSTGRES_DIR").
export PF_TEST_POSTGRES_DIR="$dir/cluster"
echo "with_postgres: $PF_TEST_POSTGRES_URL"
"$@"
