#!/usr/bin/env bash
# Installs the zenoh router zenohd 1.10.2 once into a cache outside the clone and prints its path.
# The router tests (tests/python/test_fleet.py) use it; later runs reuse the cached binary.
set -euo pipefail
version=1.10.2
root="${ZENOHD_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/attitude-service/zenohd-$version}"
bin="$root/bin/zenohd"
if [ ! -x "$bin" ] || ! "$bin" --version 2>/dev/null | grep -q "$version"; then
    echo "installing zenohd $version into $root (about 6 min, once)" >&2
    cargo install zenohd --version "$version" --locked --root "$root" >&2
fi
echo "$bin"
