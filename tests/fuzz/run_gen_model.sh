#!/usr/bin/env bash
# Fuzz the runtime model loader (mlr_gen_model_load) and the generator for a bounded time under
# ASan/UBSan, seeded with the hand-written model of tests/gen_model_file.h.
#   tests/fuzz/run_gen_model.sh [SECONDS]      (default 60)
# Builds with clang in build-fuzz/ (override with MLR_FUZZ_BUILD), as run.sh does; the corpus is
# a temporary folder. A crash leaves its input as crash-* in the current directory and makes the
# script fail.
set -euo pipefail
secs="${1:-60}"
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${MLR_FUZZ_BUILD:-$root/build-fuzz}"
command -v clang >/dev/null || { echo "run_gen_model.sh: clang is needed" >&2; exit 2; }
if [ ! -f "$build/build.ninja" ]; then
  CC=clang meson setup "$build" "$root" -Dtests=enabled -Dbuildtype=debugoptimized \
    -Dpython=disabled >/dev/null
fi
if ! meson compile -C "$build" tests/fuzz/fuzz_gen_model >"$build/fuzz-gen-compile.log" 2>&1; then
  tail -20 "$build/fuzz-gen-compile.log" >&2
  echo "run_gen_model.sh: building fuzz_gen_model failed" >&2
  exit 1
fi
corpus="$(mktemp -d "${TMPDIR:-/tmp}/mlr_fuzz_gen.XXXXXX")"
trap 'rm -rf "$corpus"' EXIT
MLR_FUZZ_WRITE_SEED="$corpus/seed.mlrgen" "$build/tests/fuzz/fuzz_gen_model"
echo "fuzzing the runtime model loader for ${secs}s"
"$build/tests/fuzz/fuzz_gen_model" -max_total_time="$secs" -max_len=8192 -timeout=10 \
  -rss_limit_mb=2048 -print_final_stats=1 "$corpus"
