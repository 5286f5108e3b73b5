#!/usr/bin/env bash
# The main job on a fresh machine: set up (scripts/setup.sh), then run `mlayer demo` on the
# bundled CMU clip, writing denoised and exaggerated BVH files, a layer figure, the layers as
# arrays and a side-by-side GIF into ./mlayer-demo/.
# Usage: bash scripts/demo.sh [mlayer demo options, e.g. --clip FILE.bvh --alpha 2.5]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh
. .venv/bin/activate
mlayer demo -o mlayer-demo "$@"
