#!/usr/bin/env bash
# Install the C library into a scratch prefix with `meson install` and build a program against
# it with pkg-config only, as a C user would: checks the soname link, the headers and mlayer.pc.
#   tests/install/run.sh [BUILD_DIR]     (default build-install)
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${1:-$root/build-install}"
prefix="$build/prefix"
if [ ! -f "$build/build.ninja" ]; then
  meson setup "$build" "$root" --prefix="$prefix" --libdir=lib -Dtests=disabled >/dev/null
fi
meson install -C "$build" --quiet >/dev/null
export PKG_CONFIG_PATH="$prefix/lib/pkgconfig"
cc -std=c11 -Wall -Werror "$root/tests/install/consumer.c" -o "$build/consumer" \
  $(pkg-config --cflags --libs mlayer)
soname="$(objdump -p "$build/consumer" | awk '/NEEDED/ && /mlayer/ {print $2}')"
echo "install: consumer links $soname"
LD_LIBRARY_PATH="$prefix/lib" "$build/consumer"
