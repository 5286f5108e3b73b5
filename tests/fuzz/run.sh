#!/usr/bin/env bash
# Fuzz the BVH reader for a bounded time under ASan/UBSan, seeded with the real clips.
#   tests/fuzz/run.sh [SECONDS]      (default 60)
# Builds with clang in build-fuzz/ (override with MLR_FUZZ_BUILD), takes the clips from
# ../shared/data/mocap (override with MLR_TEST_MOCAP_DIR) and copies them, plus short versions
# of them (first frames only), into a temporary corpus; nothing is copied into the repository.
# The mutations use the BVH keyword dictionary tests/fuzz/bvh.dict (libFuzzer's -dict=).
# A crash leaves its input as crash-* in the current directory and makes the script fail.
set -euo pipefail
secs="${1:-60}"
root="$(cd "$(dirname "$0")/../.." && pwd)"
build="${MLR_FUZZ_BUILD:-$root/build-fuzz}"
mocap="${MLR_TEST_MOCAP_DIR:-$root/../shared/data/mocap}"
command -v clang >/dev/null || { echo "run.sh: clang is needed" >&2; exit 2; }

if [ ! -f "$build/build.ninja" ]; then
  CC=clang meson setup "$build" "$root" -Dtests=enabled -Dbuildtype=debugoptimized \
    -Dpython=disabled >/dev/null
fi
if ! meson compile -C "$build" tests/fuzz/fuzz_bvh >"$build/fuzz-compile.log" 2>&1; then
  tail -20 "$build/fuzz-compile.log" >&2
  echo "run.sh: building fuzz_bvh failed (the libFuzzer/ASan runtimes come with Debian's" \
       "libclang-rt-NN-dev for clang NN)" >&2
  exit 1
fi

corpus="$(mktemp -d "${TMPDIR:-/tmp}/mlr_fuzz_bvh.XXXXXX")"
trap 'rm -rf "$corpus"' EXIT
shopt -s nullglob
for f in "$mocap"/*.bvh; do
  base="$(basename "$f" .bvh)"
  cp "$f" "$corpus/$base.bvh"
  # the hierarchy and the first 3 frames, with Frames: fixed (small seeds mutate fast)
  awk 'BEGIN{m=0; n=0}
       /^[ \t]*Frames:/ {print "Frames: 3"; next}
       m==2 {if (n<3) print; n++; next}
       /^[ \t]*Frame Time:/ {print; m=2; next}
       {print}' "$f" > "$corpus/$base.short.bvh"
done
echo "fuzzing for ${secs}s with $(ls "$corpus" | wc -l) seeds"
"$build/tests/fuzz/fuzz_bvh" -max_total_time="$secs" -max_len=131072 -timeout=10 \
  -rss_limit_mb=2048 -print_final_stats=1 -dict="$root/tests/fuzz/bvh.dict" "$corpus"
