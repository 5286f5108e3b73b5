"""The type completeness of mlayer's public API, as pyright measures it:

    pyright --verifytypes mlayer --ignoreexternal

(every symbol the package exports, with its parameters, return types and attributes, has a
declared type, not an inferred or unknown one; types from numpy and the other dependencies are
not counted against it). Prints the score and exits 1 when it is below MIN_SCORE, listing the
symbols that are not fully typed. scripts/lint.sh runs it on the installed package; pyright is
in the `lint` extra (its PyPI package runs the npm one under node).

Usage: python scripts/type_completeness.py [--min PERCENT]
"""
from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys

MIN_SCORE = 95.0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--min", type=float, default=MIN_SCORE, help="the lowest score that passes")
    args = ap.parse_args(argv)
    pyright = shutil.which("pyright")
    if pyright is None:
        print("type completeness: pyright not found (pip install the `lint` extra)",
              file=sys.stderr)
        return 1
    run = subprocess.run([pyright, "--pythonpath", sys.executable, "--verifytypes", "mlayer",
                          "--ignoreexternal", "--outputjson"], capture_output=True, text=True)
    try:
        report = json.loads(run.stdout)["typeCompleteness"]
    except (ValueError, KeyError):
        print(f"type completeness: pyright gave no report:\n{run.stdout}{run.stderr}",
              file=sys.stderr)
        return 1
    score = 100.0 * report["completenessScore"]
    counts = report["exportedSymbolCounts"]
    total = sum(counts.values())
    print(f"type completeness of mlayer (pyright --verifytypes): {score:.1f}% "
          f"({counts['withKnownType']} of {total} exported symbols fully typed; at least "
          f"{args.min:g}% passes)")
    if score >= args.min:
        return 0
    for s in report["symbols"]:
        if s["isExported"] and not s["isTypeKnown"]:
            why = "; ".join(d["message"].split("\n")[0] for d in s.get("diagnostics", []))
            print(f"  {s['name']}: {why}", file=sys.stderr)
    return 1


if __name__ == "__main__":
    sys.exit(main())
