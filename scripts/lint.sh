#!/usr/bin/env bash
# The static checks: ruff (lint rules of pyproject.toml's [tool.ruff]) over the Python of the
# package, its tests, the benchmarks, the examples and the test scripts; mypy (pyproject.toml's [tool.mypy])
# over the package; clang-format (.clang-format) over the C sources (scripts/format.sh --check);
# the type completeness of the installed package's public API (scripts/type_completeness.py:
# pyright --verifytypes, at least 95%).
# `ruff format` is not run: the Python tree is formatted by hand (see [tool.ruff.lint] in
# pyproject.toml). The tools come from the `lint` extra (scripts/setup.sh installs them).
# Usage: bash scripts/lint.sh        (after `. .venv/bin/activate`, or with the tools on PATH)
set -euo pipefail
cd "$(dirname "$0")/.."
status=0
echo "lint: ruff $(ruff --version | cut -d' ' -f2)"
ruff check bindings/python bench/python tests examples || status=1
echo "lint: mypy $(mypy --version | cut -d' ' -f2)"
mypy || status=1
echo "lint: clang-format $(clang-format --version | sed 's/.*version //')"
bash scripts/format.sh --check || status=1
echo "lint: pyright $(pyright --version 2>/dev/null | cut -d' ' -f2) --verifytypes"
python scripts/type_completeness.py || status=1
exit $status
