"""The C game loop under Xvfb: the figure is drawn, it moves, and the keys change it.

Runs examples/c/game_loop (built by meson when GLFW and OpenGL are found) headless under
xvfb-run: one simulation step per rendered frame, a screenshot (binary PPM, read back with
glReadPixels) after N frames. Checks, on the skeleton's pixels (orange bones, white joints):
each image has a figure of a plausible size inside the frame; the figure at frame 40 and at
frame 100 differ (it walked); alpha 3 (the key '3' pressed at frame 5) and the guards switched
off (key 'G') change the frame-100 pose. Exits 77 (meson: skipped) with the reason when the
program was not built (no GLFW/OpenGL) or xvfb-run is missing.

    python3 tests/game_loop/check_game_loop.py EXE CLIP OUTDIR
    python3 tests/game_loop/check_game_loop.py --skip REASON
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys

SIZE = (480, 320)


def skip(reason: str) -> None:
    print(f"SKIP game_loop: {reason}", file=sys.stderr)
    sys.exit(77)


def read_ppm(path: str) -> tuple[int, int, bytes]:
    with open(path, "rb") as f:
        data = f.read()
    parts = data.split(maxsplit=4)
    if parts[0] != b"P6" or parts[3] != b"255":
        raise SystemExit(f"{path}: not a binary PPM")
    w, h = int(parts[1]), int(parts[2])
    pixels = parts[4]
    if len(pixels) != 3 * w * h:
        raise SystemExit(f"{path}: {len(pixels)} bytes of pixels, expected {3 * w * h}")
    return w, h, pixels


def figure(path: str) -> set[int]:
    """Indices of the skeleton's pixels: orange bones or white joints."""
    w, h, px = read_ppm(path)
    if (w, h) != SIZE:
        raise SystemExit(f"{path}: {w}x{h}, expected {SIZE[0]}x{SIZE[1]}")
    out = set()
    for i in range(w * h):
        r, g, b = px[3 * i], px[3 * i + 1], px[3 * i + 2]
        if (r >= 200 and 100 <= g <= 180 and b <= 60) or (r >= 240 and g >= 240 and b >= 240):
            out.add(i)
    return out


def shoot(exe: str, clip: str, out: str, frames: int, *extra: str) -> set[int]:
    cmd = ["xvfb-run", "-a", "-s", "-screen 0 1024x768x24", exe, clip, "--frames", str(frames),
           "--screenshot", out, "--size", f"{SIZE[0]}x{SIZE[1]}", *extra]
    res = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    sys.stdout.write(res.stdout)
    if res.returncode != 0:
        sys.stderr.write(res.stderr)
        raise SystemExit(f"game_loop exited with {res.returncode}: {' '.join(cmd)}")
    mask = figure(out)
    n = SIZE[0] * SIZE[1]
    print(f"{os.path.basename(out)}: {len(mask)} figure pixels")
    if not 300 <= len(mask) <= 0.3 * n:
        raise SystemExit(f"{out}: {len(mask)} figure pixels: no figure drawn (or all figure)")
    return mask


def differ(a: set[int], b: set[int]) -> float:
    """The share of the figures' pixels that are in one image only."""
    return len(a ^ b) / len(a | b)


def main() -> None:
    if len(sys.argv) == 3 and sys.argv[1] == "--skip":
        skip(sys.argv[2])
    if len(sys.argv) != 4:
        raise SystemExit(__doc__)
    exe, clip, outdir = sys.argv[1:]
    if shutil.which("xvfb-run") is None:
        skip("xvfb-run not found (Debian package xvfb)")
    os.makedirs(outdir, exist_ok=True)
    shot = lambda name, frames, *extra: shoot(  # noqa: E731
        exe, clip, os.path.join(outdir, name), frames, *extra)
    early = shot("frame040.ppm", 40)
    late = shot("frame100.ppm", 100)
    alpha3 = shot("frame100_alpha3.ppm", 100, "--press", "5:3")
    unguarded = shot("frame100_alpha3_noguards.ppm", 100, "--press", "5:3", "--press", "5:G")
    moved = differ(early, late)
    print(f"figure pixels in one of frames 40 and 100 only: {moved:.2f}")
    if moved < 0.3:
        raise SystemExit(f"the figure did not move between frames 40 and 100 ({moved:.2f})")
    styled = differ(late, alpha3)
    print(f"alpha 3 against alpha 1 at frame 100: {styled:.2f}")
    if styled < 0.05:
        raise SystemExit(f"key '3' (alpha 3) did not change the pose ({styled:.2f})")
    guarded = differ(alpha3, unguarded)
    print(f"alpha 3 with the guards against without at frame 100: {guarded:.2f}")
    if guarded < 0.02:
        raise SystemExit(f"key 'G' (guards off) did not change the pose ({guarded:.2f})")
    print("game_loop: ok")


if __name__ == "__main__":
    main()
