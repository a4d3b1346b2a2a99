#!/usr/bin/env bash
# Installs what the `dds` feature's C build needs and a fresh Debian/Ubuntu machine lacks (scripts/test-all.sh
# runs it): the `dds` feature links zenoh-plugin-ros2dds, whose cyclors crate builds CycloneDDS from source
# with cmake and generates its Rust bindings with bindgen, which loads libclang. gcc/g++ and make are
# assumed (Rust's own builds need a C toolchain). Nothing is done when both are there; otherwise apt-get
# installs them (as root, or through sudo), and a machine without apt-get gets a message saying what to
# install.
set -euo pipefail

have_libclang() {
    # clang-sys (bindgen's loader) looks for libclang.so* in these places, or where LIBCLANG_PATH says.
    if [ -n "${LIBCLANG_PATH:-}" ] && compgen -G "$LIBCLANG_PATH/libclang*.so*" >/dev/null; then
        return 0
    fi
    # (libclang-cpp, which Debian's llvm packages bring, is another library.)
    compgen -G "/usr/lib/llvm-*/lib/libclang.so*" >/dev/null ||
        compgen -G "/usr/lib/*/libclang-[0-9]*.so*" >/dev/null ||
        compgen -G "/usr/lib/*/libclang.so*" >/dev/null ||
        compgen -G "/usr/lib/libclang.so*" >/dev/null
}

missing=()
command -v cmake >/dev/null || missing+=(cmake)
# libclang-dev brings libclang.so and clang's own headers (stddef.h), both of which bindgen needs.
have_libclang || missing+=(libclang-dev)
[ ${#missing[@]} -eq 0 ] && exit 0

if ! command -v apt-get >/dev/null; then
    echo "install-build-deps: the dds feature needs ${missing[*]}: install them with your package manager" >&2
    exit 1
fi
sudo=()
[ "$(id -u)" -eq 0 ] || sudo=(sudo)
echo "install-build-deps: apt-get install ${missing[*]} (the dds feature's CycloneDDS build)" >&2
export DEBIAN_FRONTEND=noninteractive
"${sudo[@]}" apt-get update -qq >&2
"${sudo[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}" >&2
