#!/usr/bin/env bash
# Build MATIEC (iec2c, the IEC 61131-3 compiler of Beremiz and OpenPLC) for tests/plc/test_matiec.py.
#
# MATIEC is GPL-3: a test tool only. It is built from a source archive OUTSIDE this repository
# (default: ../shared/tools/matiec/matiec-*.tar.gz beside the repository, beside a worktree's main
# checkout, or beside the local repository a fresh clone was made from; or the archive that
# CTRLBLOCKS_MATIEC_ARCHIVE names) into a cache directory
# (default: ~/.cache/ctrlblocks/matiec-<archive name>), never copied into the project.
#
#   tests/plc/build_matiec.sh [ARCHIVE] [CACHE_DIR]
#   tests/plc/build_matiec.sh --archive      (prints the archive it would build, or exits 2)
#
# Prints the directory that holds iec2c and lib/ (what CTRLBLOCKS_MATIEC names) on stdout; the
# build's own output goes to CACHE_DIR/build.log. A second run with the same archive is a no-op.
# Needs gcc, make, flex, bison, autoconf, automake, libtool (Debian packages of those names).
# Exit codes: 2 no source archive, 3 a build tool missing, 4 the build failed (its log's tail
# on stderr).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
only_find=""
if [ "${1:-}" = "--archive" ]; then only_find=1; shift; fi
archive="${1:-}"
archive="${archive:-${CTRLBLOCKS_MATIEC_ARCHIVE:-}}"
# the checkouts to look beside: this one; for a git worktree its main checkout; for a clone
# of a local repository (CI's fresh clone) that repository and its main checkout (3 levels)
checkouts() {
    local dir="$1" depth="${2:-0}" common origin
    echo "$dir"
    common="$(cd "$dir" && git rev-parse --path-format=absolute --git-common-dir 2>/dev/null || true)"
    [ -n "$common" ] && dirname "$common"
    origin="$(cd "$dir" && git config --get remote.origin.url 2>/dev/null || true)"
    origin="${origin#file://}"
    if [ -n "$origin" ] && [ -d "$origin" ] && [ "$depth" -lt 3 ]; then
        checkouts "$(cd "$origin" && pwd)" $((depth + 1))
    fi
}
places() { checkouts "$root" | awk '!seen[$0]++'; }
if [ -z "$archive" ]; then
    for dir in $(places); do
        archive="$(ls "$dir"/../shared/tools/matiec/matiec-*.tar.gz 2>/dev/null | head -n 1 || true)"
        [ -n "$archive" ] && break
    done
fi
if [ -z "$archive" ] || [ ! -f "$archive" ]; then
    echo "build_matiec: no MATIEC source archive (looked for ../shared/tools/matiec/matiec-*.tar.gz" \
        "beside $(places | tr '\n' ' ')and CTRLBLOCKS_MATIEC_ARCHIVE)" >&2
    exit 2
fi
if [ -n "$only_find" ]; then echo "$archive"; exit 0; fi
name="$(basename "$archive" .tar.gz)"
cache="${2:-${XDG_CACHE_HOME:-$HOME/.cache}/ctrlblocks/$name}"
if [ -x "$cache/matiec/iec2c" ] && [ -f "$cache/matiec/lib/C/iec_std_lib.h" ]; then
    echo "$cache/matiec"
    exit 0
fi
for tool in gcc make flex bison autoreconf automake libtoolize; do
    command -v "$tool" >/dev/null || { echo "build_matiec: $tool is missing" >&2; exit 3; }
done
rm -rf "$cache.tmp" && mkdir -p "$cache.tmp"
tar -xzf "$archive" -C "$cache.tmp"
(
    cd "$cache.tmp/matiec"
    autoreconf -i && ./configure && make -j"$(nproc 2>/dev/null || echo 2)"
) >"$cache.tmp/build.log" 2>&1 || { tail -n 30 "$cache.tmp/build.log" >&2; exit 4; }
rm -rf "$cache" && mv "$cache.tmp" "$cache"
echo "$cache/matiec"
