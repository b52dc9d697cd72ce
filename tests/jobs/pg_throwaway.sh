#!/usr/bin/env bash
# A throwaway PostgreSQL cluster for the queue tests (issue 13): its own data
# directory, listening on 127.0.0.1 only, run as an unprivileged user.
#
#   pg_throwaway.sh start DIR PORT   initdb + start; prints the URL of database "photonfarm"
#   pg_throwaway.sh stop DIR         stops it and removes DIR
#   pg_throwaway.sh restart DIR      restarts the server (tests of a dropped connection)
#
# PostgreSQL refuses to run as root: as root, the cluster runs as "nobody".
set -euo pipefail

bin=$(ls -d /usr/lib/postgresql/*/bin 2>/dev/null | sort -V | tail -n 1)
if [ -z "$bin" ]; then
  echo "pg_throwaway: PostgreSQL is not installed (apt-get install postgresql)" >&2
  exit 2
fi

as_owner() {
  if [ "$(id -u)" -eq 0 ]; then
    runuser -u nobody -- "$@"
  else
    "$@"
  fi
}

command=${1:-}
dir=${2:-}
[ -n "$dir" ] || { echo "usage: $0 start DIR PORT | stop DIR | restart DIR" >&2; exit 2; }

case "$command" in
  start)
    port=${3:?port}
    mkdir -p "$dir"
    [ "$(id -u)" -ne 0 ] || chown nobody "$dir"
    as_owner "$bin/initdb" -D "$dir/data" -U photonfarm --auth=trust -E UTF8 --locale=C.UTF-8 \
      > "$dir/initdb.log" 2>&1
    as_owner "$bin/pg_ctl" -D "$dir/data" -l "$dir/server.log" -w \
      -o "-p $port -k $dir -c listen_addresses=127.0.0.1 -c fsync=off" start > /dev/null
    as_owner "$bin/createdb" -h 127.0.0.1 -p "$port" -U photonfarm photonfarm
    echo "postgresql://photonfarm@127.0.0.1:$port/photonfarm"
    ;;
  stop)
    if [ -d "$dir/data" ]; then
      as_owner "$bin/pg_ctl" -D "$dir/data" -m immediate -w stop > /dev/null 2>&1 || true
    fi
    rm -rf "$dir"
    ;;
  restart)
    as_owner "$bin/pg_ctl" -D "$dir/data" -m fast -w restart > /dev/null
    ;;
  *)
    echo "usage: $0 start DIR PORT | stop DIR | restart DIR" >&2
    exit 2
    ;;
esac
