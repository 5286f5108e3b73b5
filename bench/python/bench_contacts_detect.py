"""C detect_contacts vs the numpy reference (test_contacts.ref_detect_contacts); median of 31
interleaved runs. 'detection' = everything after forward kinematics (FK cached for both)."""
import pathlib
import statistics
import sys
import time

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parents[2] / "bindings/python/tests"))
import mlayer  # noqa: E402
import test_contacts as T  # noqa: E402

D = str(pathlib.Path(__file__).resolve().parents[3] / "shared/data/mocap") + "/"
for name in ["lafan1_clip_a.bvh", "cmu_01_01_playground_jumps.bvh"]:
    m = mlayer.read_bvh(D + name)
    names, c = mlayer.detect_contacts(m)
    fk = m.forward_kinematics()

    class Cached(mlayer.Motion):
        def forward_kinematics(self):  # FK computed once
            return fk
    cached = Cached(m.skeleton, m.frame_time, m.root_pos, m.rot, m.trans)
    runs = {"C": [], "numpy": [], "C det": [], "numpy det": []}
    for _ in range(31):
        for key, f in (("C", lambda: mlayer.detect_contacts(m)),
                       ("numpy", lambda: T.ref_detect_contacts(m)),
                       ("C det", lambda: mlayer.detect_contacts(cached)),
                       ("numpy det", lambda: T.ref_detect_contacts(cached))):
            t0 = time.perf_counter()
            f()
            runs[key].append(time.perf_counter() - t0)
    med = {k: statistics.median(v) * 1e3 for k, v in runs.items()}
    lo = {k: min(v) * 1e3 for k, v in runs.items()}
    print(f"{name}: {m.n_frames} frames x {m.n_joints} joints, {len(names)} points, "
          f"{m.fps:g} fps")
    print(f"  whole call (FK included): C {med['C']:.2f} ms, numpy {med['numpy']:.2f} ms, "
          f"numpy/C {med['numpy'] / med['C']:.2f}")
    print(f"  detection (FK cached):    C {med['C det']:.2f} ms, numpy {med['numpy det']:.2f} ms, "
          f"numpy/C {med['numpy det'] / med['C det']:.2f}")
    print(f"  fastest runs: whole C {lo['C']:.2f} / numpy {lo['numpy']:.2f} ms "
          f"({lo['numpy'] / lo['C']:.2f}); detection C {lo['C det']:.2f} / numpy "
          f"{lo['numpy det']:.2f} ms ({lo['numpy det'] / lo['C det']:.2f})")
