"""Compile every public header on its own as strict C99, and the umbrella header as C++."""
import argparse
import pathlib
import subprocess
import sys
import tempfile


def compile_one(compiler, flags, source_text, suffix, includes):
    with tempfile.TemporaryDirectory() as tmp:
        src = pathlib.Path(tmp) / ("probe" + suffix)
        src.write_text(source_text)
        cmd = [compiler, *flags, *(f"-I{d}" for d in includes), "-c", str(src), "-o",
               str(pathlib.Path(tmp) / "probe.o")]
        r = subprocess.run(cmd, capture_output=True, text=True)
        return r.returncode, r.stderr


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--cc", required=True)
    ap.add_argument("--cxx", default="")
    ap.add_argument("src_include")
    ap.add_argument("build_include")
    a = ap.parse_args()
    includes = [a.src_include, a.build_include, f"{a.build_include}/mlayer"]
    headers = sorted(p.name for p in pathlib.Path(a.src_include, "mlayer").glob("*.h"))
    failed = 0
    cflags = ["-std=c99", "-pedantic", "-Wall", "-Wextra", "-Werror"]
    for h in headers:
        code, err = compile_one(a.cc, cflags, f"#include <mlayer/{h}>\nint mlr_probe;\n", ".c",
                                includes)
        print(f"{'ok  ' if code == 0 else 'FAIL'} C99 {h}")
        if code:
            print(err)
            failed += 1
    if a.cxx:
        code, err = compile_one(a.cxx, ["-std=c++11", "-pedantic", "-Wall", "-Werror"],
                                "#include <mlayer/mlayer.h>\nint mlr_probe;\n", ".cpp", includes)
        print(f"{'ok  ' if code == 0 else 'FAIL'} C++ mlayer.h")
        if code:
            print(err)
            failed += 1
    print(f"{len(headers) + bool(a.cxx) - failed} passed, {failed} failed")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
