"""The C core's folders include only downward (docs/ARCHITECTURE.md, "Who calls whom").

    python check_layers.py LIBMLAYER_DIR

Every C file of the library sits in one of the folders of LAYERS, and every `#include "..."`
of it names a folder ("math/lgs_internal.h") that the including file's folder may use: its own
and those listed for it. `mlayer/...` (the public headers) and <...> are always allowed.
"""
from __future__ import annotations

import re
import sys
from pathlib import Path

#: each folder, lower layers first, with the folders below it that it may include from
LAYERS: dict[str, set[str]] = {
    "common": set(),
    "math": {"common"},
    "motion": {"common", "math"},
    "io": {"common", "math", "motion"},
    "layers": {"common", "math", "motion"},
    "manifold": {"common", "math"},
    "guards": {"common", "math", "motion"},
    "generate": {"common", "math", "motion", "io", "manifold", "guards"},
    "stream": {"common", "math", "motion", "layers", "guards"},
    "pipeline": {"common", "math", "motion", "layers", "guards"},
    "retarget": {"common", "math", "motion", "guards"},
}

INCLUDE = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)


def check(root: Path) -> list[str]:
    errors = []
    for path in sorted(root.rglob("*")):
        if path.suffix not in (".c", ".h"):
            continue
        rel = path.relative_to(root)
        folder = rel.parts[0] if len(rel.parts) == 2 else None
        if folder not in LAYERS:
            errors.append(f"{rel}: not in one of the folders {', '.join(LAYERS)}")
            continue
        for name in INCLUDE.findall(path.read_text()):
            if name.startswith("mlayer/"):
                continue
            parts = name.split("/")
            if len(parts) != 2 or parts[0] not in LAYERS:
                errors.append(f'{rel}: #include "{name}" does not name its folder')
            elif not (root / name).is_file():
                errors.append(f'{rel}: #include "{name}": no such file')
            elif parts[0] != folder and parts[0] not in LAYERS[folder]:
                errors.append(f'{rel}: #include "{name}" points up ({folder} may include '
                              f'{", ".join(sorted(LAYERS[folder] | {folder}))})')
    return errors


def main() -> None:
    errors = check(Path(sys.argv[1]))
    for e in errors:
        print(e, file=sys.stderr)
    if errors:
        sys.exit(1)
    print("check_layers: every include of the C core points down or into its own folder")


if __name__ == "__main__":
    main()
