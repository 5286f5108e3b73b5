#!/usr/bin/env bash
# Format the C sources with clang-format and the style of .clang-format.
#   bash scripts/format.sh --check   list the files that are not formatted; exit 1 if any
#   bash scripts/format.sh --fix     reformat them in place
# Files: the tracked *.c and *.h under include/, libmlayer/, tests/, bench/ and examples/.
# clang-format comes from the `lint` extra (pip, pinned so that every machine formats alike);
# CLANG_FORMAT=... picks another binary.
set -euo pipefail
cd "$(dirname "$0")/.."
mode=${1:---check}
CF=${CLANG_FORMAT:-clang-format}
if ! command -v "$CF" >/dev/null; then
  echo "format.sh: $CF not found: pip install -e '.[lint]' (or bash scripts/setup.sh)" >&2
  exit 2
fi
mapfile -t files < <(git ls-files -- 'include/*.c' 'include/*.h' 'libmlayer/*.c' 'libmlayer/*.h' \
  'tests/*.c' 'tests/*.h' 'bench/*.c' 'bench/*.h' 'examples/*.c' 'examples/*.h')
case "$mode" in
  --fix)
    "$CF" -i --style=file "${files[@]}"
    echo "format.sh: formatted ${#files[@]} files" ;;
  --check)
    bad=()
    for f in "${files[@]}"; do
      "$CF" --style=file --dry-run -Werror "$f" >/dev/null 2>&1 || bad+=("$f")
    done
    if [ ${#bad[@]} -gt 0 ]; then
      printf '%s\n' "${bad[@]}" >&2
      echo "format.sh: ${#bad[@]} of ${#files[@]} C files need formatting: bash scripts/format.sh --fix" >&2
      exit 1
    fi
    echo "format.sh: ${#files[@]} C files formatted" ;;
  *) echo "usage: bash scripts/format.sh --check | --fix" >&2; exit 2 ;;
esac
