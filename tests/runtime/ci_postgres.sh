#!/usr/bin/env bash
# Start a local PostgreSQL server on 127.0.0.1 for the PostgreSQL historian test
# and print its DSN (for CTRLBLOCKS_TEST_PG_DSN).  Installs Debian's postgresql
# package when missing.  Prints nothing and exits non-zero when it cannot; the
# test then skips with a message saying why.
set -euo pipefail
exec 3>&1 1>&2  # progress to stderr; only the DSN goes to stdout
if ! command -v pg_ctlcluster >/dev/null 2>&1 || ! ls /usr/lib/postgresql/*/bin/postgres >/dev/null 2>&1; then
    command -v apt-get >/dev/null 2>&1 || { echo "no apt-get: cannot install PostgreSQL"; exit 1; }
    (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq postgresql) >/dev/null
fi
ver=$(ls /usr/lib/postgresql | sort -V | tail -1)
if ! pg_lsclusters -h | awk '{print $1" "$2}' | grep -qx "$ver main"; then
    pg_createcluster "$ver" main >/dev/null 3>&-
fi
pg_ctlcluster "$ver" main start 3>&- 2>/dev/null || true
port=$(pg_lsclusters -h | awk -v v="$ver" '$1==v && $2=="main" {print $3}')
for _ in $(seq 1 30); do
    su postgres -c "psql -p $port -qtAc 'select 1'" >/dev/null 2>&1 && break
    sleep 1
done
su postgres -c "psql -p $port -qtAc \"SELECT 1 FROM pg_roles WHERE rolname='ctrlblocks'\"" | grep -q 1 \
    || su postgres -c "psql -p $port -qc \"CREATE ROLE ctrlblocks LOGIN PASSWORD 'ctrlblocks'\""
su postgres -c "psql -p $port -qtAc \"SELECT 1 FROM pg_database WHERE datname='ctrlblocks_test'\"" | grep -q 1 \
    || su postgres -c "createdb -p $port -O ctrlblocks ctrlblocks_test"
echo "postgresql://ctrlblocks:ctrlblocks@127.0.0.1:$port/ctrlblocks_test" >&3
