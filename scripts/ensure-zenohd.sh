#!/usr/bin/env bash
# Installs the zenoh router zenohd 1.10.2 and its REST plugin once into a cache outside the clone and
# prints zenohd's path; the plugin is <cache>/lib/libzenoh_plugin_rest.so (zenohd --plugin-search-dir
# <cache>/lib --rest-http-port PORT). The router tests (tests/python/test_fleet.py, test_metrics.py)
# use them; later runs reuse the cached files.
#
# `cargo install zenohd` builds no plugin, and zenohd loads the REST plugin only as a dynamic library
# built with the same zenoh version, zenoh features and rustc: it is built here from the crate's
# published source and lock file, with its default features (zenohd's zenoh features). Both builds share
# one target directory, so the plugin reuses the zenoh crates zenohd's build compiled (the same versions
# and features) instead of building them a second time.
#
# Several checkouts (worktrees, parallel test runs) share the cache: one lock serialises them, so a run
# never sees or removes another's half-built files.
set -euo pipefail
version=1.10.2
root="${ZENOHD_CACHE:-${XDG_CACHE_HOME:-$HOME/.cache}/attitude-service/zenohd-$version}"
bin="$root/bin/zenohd"
plugin="$root/lib/libzenoh_plugin_rest.so"
build="$root/build"
mkdir -p "$root"
exec 9> "$root.lock"
flock 9
rustc_now="$(rustc -V)"
# The plugin must be built by the rustc that built zenohd (zenohd refuses it otherwise).
if [ -x "$bin" ] && ! "$bin" --version 2>/dev/null | grep -qF "built with $rustc_now"; then
    echo "zenohd in $root was built by another rustc; rebuilding it and its plugin" >&2
    rm -rf "$root/bin" "$root/lib"
fi
if [ ! -x "$bin" ] || ! "$bin" --version 2>/dev/null | grep -q "$version"; then
    echo "installing zenohd $version into $root (about 6 min, once)" >&2
    cargo install zenohd --version "$version" --locked --root "$root" --target-dir "$build" >&2
fi
if [ ! -f "$plugin" ]; then
    echo "building zenoh-plugin-rest $version into $root/lib (about 8 min, once)" >&2
    repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
    # The service depends on the crate (statically linked): its source is in Cargo's registry.
    cargo fetch --locked --manifest-path "$repo/Cargo.toml" >&2
    src="$(find "${CARGO_HOME:-$HOME/.cargo}/registry/src" -maxdepth 2 -type d \
        -name "zenoh-plugin-rest-$version" -print -quit)"
    [ -n "$src" ] || { echo "zenoh-plugin-rest-$version is not in Cargo's registry" >&2; exit 1; }
    work="$root/src-rest"
    rm -rf "$work" "$root/build-rest"
    mkdir -p "$root/lib"
    cp -r "$src" "$work"
    cargo build --release --locked --lib --manifest-path "$work/Cargo.toml" --target-dir "$build" >&2
    cp "$build/release/libzenoh_plugin_rest.so" "$plugin.tmp"
    mv "$plugin.tmp" "$plugin"
    rm -rf "$work"
fi
rm -rf "$build"
echo "$bin"
