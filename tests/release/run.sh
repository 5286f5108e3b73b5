#!/usr/bin/env bash
# Release check, as a user of the published files would meet them:
#  1. `python -m build` makes the sdist from the git tree (HEAD, through meson dist) and the
#     wheel from that sdist; the sdist also configures on its own with the C tests enabled;
#  2. check_dists.py checks both file lists and the wheel's abi3 tag;
#  3. the wheel's extension must not need libcholmod (readelf: no NEEDED entry, no cholmod_
#     symbol);
#  4. the wheel is installed into a fresh venv and smoke.py runs there with every libcholmod
#     file hidden (a private mount namespace binds /dev/null over them, where unshare is
#     allowed; the checkout's own CHOLMOD build must then fail to import, which shows the
#     hiding works), on this Python and on the newest later Python found (python3.13 or
#     python3.12 on PATH or under pyenv; MLAYER_RELEASE_PYTHONS names others, "" none), the
#     same abi3 wheel both times.
# Commits count: the sdist holds HEAD's tree, not uncommitted changes.
#   tests/release/run.sh [OUT_DIR]     (default build-release)
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
out="${1:-$root/build-release}"
here="$root/tests/release"
rm -rf "$out"
mkdir -p "$out"
version="$(sed -n "s/^ *version: '\([0-9.]*\)',\$/\1/p" "$root/meson.build" | head -1)"
[ -n "$version" ] || { echo "release: no project version in meson.build" >&2; exit 1; }

if ! python -m build --no-isolation --outdir "$out/dist" "$root" >"$out/build.log" 2>&1; then
  tail -40 "$out/build.log"; echo "release: python -m build failed" >&2; exit 1
fi
sdist="$out/dist/mlayer-$version.tar.gz"
wheel="$(ls "$out/dist"/mlayer-"$version"-*.whl)"
echo "release: built $(basename "$sdist") and $(basename "$wheel")"
python "$here/check_dists.py" "$root" "$sdist" "$wheel" "$version"

# the sdist alone configures the whole project, C tests included
tar -xzf "$sdist" -C "$out"
meson setup "$out/sdist-build" "$out/mlayer-$version" -Dtests=enabled >"$out/sdist-setup.log" 2>&1 \
  || { tail -20 "$out/sdist-setup.log"; echo "release: the sdist does not configure" >&2; exit 1; }

mkdir -p "$out/wheel"
python -m zipfile -e "$wheel" "$out/wheel"
ext="$out/wheel/mlayer/_mlayer.abi3.so"
needed="$(readelf -d "$ext" | awk '/NEEDED/ {gsub(/[][]/, "", $NF); print $NF}' | tr '\n' ' ')"
echo "release: the extension needs: $needed"
if echo "$needed" | grep -qiE 'cholmod|suitesparse|amd|blas|lapack'; then
  echo "release: the wheel's extension links SuiteSparse" >&2; exit 1
fi
if nm -D --undefined-only "$ext" | grep -q cholmod_; then
  echo "release: the wheel's extension refers to cholmod_ symbols" >&2; exit 1
fi

# every libcholmod file the dynamic loader knows, hidden in a private mount namespace
mapfile -t cholmod_files < <(ldconfig -p | awk '/libcholmod\.so/ {print $NF}' | xargs -r readlink -f | sort -u)
unshare_cmd=()
if [ "${#cholmod_files[@]}" -gt 0 ]; then
  if [ "$(id -u)" -eq 0 ]; then unshare_cmd=(unshare -m); else unshare_cmd=(unshare -rm); fi
  "${unshare_cmd[@]}" true 2>/dev/null || unshare_cmd=()
fi
hide='for f in '"${cholmod_files[*]:-}"'; do mount --bind /dev/null "$f"; done'
dev_ext="$(ls "$root"/.venv/lib/python3*/site-packages/mlayer/_mlayer*.so 2>/dev/null | head -1 || true)"

smoke() {  # smoke INTERPRETER NAME
  local venv="$out/venv-$2"
  "$1" -m venv "$venv"
  "$venv/bin/python" -m pip install -q "$wheel" >"$out/pip-$2.log" 2>&1 \
    || { tail -20 "$out/pip-$2.log"; echo "release: pip install of the wheel failed ($2)" >&2; exit 1; }
  if [ "${#unshare_cmd[@]}" -gt 0 ]; then
    local control=true note=""
    if [ -n "$dev_ext" ] && ldd "$dev_ext" | grep -q libcholmod; then
      # the checkout's build links CHOLMOD: with the library hidden it must not import
      control="if \"$root/.venv/bin/python\" -c 'import mlayer' 2>/dev/null; then
                 echo 'release: libcholmod is not hidden: the CHOLMOD build imports' >&2; exit 1; fi"
      note="; the checkout's CHOLMOD build failed to import there"
    fi
    (cd "$out" && "${unshare_cmd[@]}" bash -c "set -e; $hide; $control; \"$venv/bin/python\" \"$here/smoke.py\" $version \"$out/smoke-$2\"")
    echo "release: ($2) ran with ${cholmod_files[*]} hidden$note"
  else
    (cd "$out" && "$venv/bin/python" "$here/smoke.py" "$version" "$out/smoke-$2")
    echo "release: ($2) libcholmod not hidden (${#cholmod_files[@]} files; no unshare here): the extension needs none and smoke.py found none loaded"
  fi
}

smoke python main
pyenv_root="${PYENV_ROOT:-$HOME/.pyenv}"
default_pythons="python3.13 $(ls -d "$pyenv_root"/versions/3.13*/bin/python3 2>/dev/null | tail -1)
                 python3.12 $(ls -d "$pyenv_root"/versions/3.12*/bin/python3 2>/dev/null | tail -1)"
for py in ${MLAYER_RELEASE_PYTHONS-$default_pythons}; do
  if "$py" -c 'import sys; assert sys.version_info >= (3, 12)' 2>/dev/null; then
    smoke "$py" "$("$py" -c 'import sys; print("py%d%d" % sys.version_info[:2])')"
    break
  fi
done
