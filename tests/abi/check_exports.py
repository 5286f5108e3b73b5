"""The shared library exports exactly the symbols named in mlayer.map (and all of them)."""
import re
import subprocess
import sys


def main():
    lib, mapfile = sys.argv[1], sys.argv[2]
    text = re.sub(r"/\*.*?\*/", "", open(mapfile).read(), flags=re.S)
    wanted = set()
    for block in re.findall(r"global:(.*?)(?:local:|\})", text, flags=re.S):
        wanted.update(s.strip() for s in block.split(";") if s.strip())
    out = subprocess.run(["nm", "-D", "--defined-only", lib], capture_output=True, text=True,
                         check=True).stdout
    exported = set()
    for line in out.splitlines():
        parts = line.split()
        if len(parts) == 3 and parts[1] in "TDBRVW":
            exported.add(parts[2].split("@")[0])
    missing, extra = wanted - exported, exported - wanted
    for s in sorted(missing):
        print(f"missing from the library: {s}")
    for s in sorted(extra):
        print(f"exported but not in mlayer.map: {s}")
    bad_prefix = [s for s in exported if not s.startswith("mlr_")]
    for s in bad_prefix:
        print(f"exported symbol without the mlr_ prefix: {s}")
    failed = len(missing) + len(extra) + len(bad_prefix)
    print(f"{len(wanted & exported)} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
