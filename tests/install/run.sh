#!/usr/bin/env bash
# Install the C library into a scratch prefix with `meson install` and build a program against
# it as a C user would: with pkg-config only, and with CMake's find_package(mlayer CONFIG).
# Then the same with the static library (-Ddefault_library=static, pkg-config --static).
# Checks the soname link, the headers, mlayer.pc and the CMake package.
#   tests/install/run.sh [BUILD_DIR]     (default build-install)
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${1:-$root/build-install}"

consume() { # $1: build dir, $2: "shared" or "static"
  local b="$1" kind="$2" prefix="$1/prefix"
  if [ ! -f "$b/build.ninja" ]; then
    meson setup "$b" "$root" --prefix="$prefix" --libdir=lib -Dtests=disabled \
      -Ddefault_library="$kind" >/dev/null
  fi
  meson install -C "$b" --quiet >/dev/null
  export PKG_CONFIG_PATH="$prefix/lib/pkgconfig"
  local static_flag=""
  [ "$kind" = static ] && static_flag="--static"
  # shellcheck disable=SC2046
  cc -std=c11 -Wall -Werror "$root/tests/install/consumer.c" -o "$b/consumer" \
    $(pkg-config --cflags --libs $static_flag mlayer)
  local needed
  needed="$(objdump -p "$b/consumer" | awk '/NEEDED/ && /mlayer/ {print $2}')"
  if [ "$kind" = shared ]; then
    [ -n "$needed" ] || { echo "install: the consumer does not link libmlayer.so" >&2; exit 1; }
    echo "install: pkg-config consumer links $needed"
  else
    [ -z "$needed" ] || { echo "install: the static consumer needs $needed" >&2; exit 1; }
    echo "install: pkg-config --static consumer has libmlayer linked in"
  fi
  LD_LIBRARY_PATH="$prefix/lib" "$b/consumer"
  if command -v cmake >/dev/null 2>&1; then
    rm -rf "$b/cmake-consumer"
    cmake -S "$root/tests/install/cmake" -B "$b/cmake-consumer" -DCMAKE_PREFIX_PATH="$prefix" \
      -DCMAKE_BUILD_TYPE=Release >/dev/null
    cmake --build "$b/cmake-consumer" >/dev/null
    echo "install: find_package(mlayer CONFIG) consumer ($kind) built"
    LD_LIBRARY_PATH="$prefix/lib" "$b/cmake-consumer/consumer"
  else
    echo "install: cmake not found, the CMake package was not checked" >&2
    exit 1
  fi
}

consume "$build" shared
consume "$build-static" static
