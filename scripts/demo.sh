#!/usr/bin/env bash
# The main job on a fresh machine: set up what the demo needs (scripts/setup.sh --demo: a C
# compiler, numpy, cffi, matplotlib, Pillow; a re-run with nothing changed skips every step and
# takes seconds), then run `mlayer demo` on the bundled CMU clip, writing denoised and
# exaggerated BVH files, a layer figure, the layers as arrays and a side-by-side GIF into
# ./mlayer-demo/.
# Usage: bash scripts/demo.sh [mlayer demo options, e.g. --clip FILE.bvh --alpha 2.5]
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup.sh --demo
. .venv/bin/activate
mlayer demo -o mlayer-demo "$@"
