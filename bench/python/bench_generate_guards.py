"""Guards of generated motion (issue 18 item 6): per walk and start, foot sliding of generated
motion against the training clip (raw and guarded, with the generated contacts), knee folds and
reversals, floor penetration and the body offset. Run from the repository root:
    python bench/python/bench_generate_guards.py
"""
import numpy as np
import pathlib
import sys
sys.path.insert(0, "bindings/python/tests/manifold")
from test_generate_guards import WALKS, STARTS, _fit
from mlayer.guards.metrics import body_height, foot_sliding
from mlayer.guards.plausibility import hinge_violations
from mlayer.guards.contacts import contact_positions
mocap = pathlib.Path("../shared/data/mocap")
for clip, frames, opts in WALKS:
    m, model = _fit(mocap, clip, frames, opts)
    n = model.contact_names
    train = foot_sliding(m, model.contacts, n)
    h = body_height(m)
    lim = model.joint_limits()
    for sf, seed in STARTS:
        raw = model.generate(300, start_frame=sf, seed=seed, guards=False)
        out, info = model.generate(300, start_frame=sf, seed=seed, return_info=True)
        c = info["contacts"]
        vr, vg = hinge_violations(m, raw, lim), hinge_violations(m, out, lim)
        pr = contact_positions(raw, n)[..., 1].min(1)
        pg = contact_positions(out, n)[..., 1].min(1)
        fl = model.floor_height
        b = model.body_joint
        d = np.linalg.norm(out.positions()[:, b] - raw.positions()[:, b], axis=1)
        print(f"{clip} start {sf} seed {seed}: train {train:.3g}/s; "
              f"sliding raw {foot_sliding(raw, c, n)/train:.2f}x, "
              f"guarded {foot_sliding(out, c, n)/train:.2f}x; contacts {c.mean():.2f} "
              f"(train {model.contacts.mean():.2f}); "
              f"fold raw/guarded {vr['fold_frames']}/{vg['fold_frames']}, "
              f"reversal {vr['reversal_frames']}/{vg['reversal_frames']}; "
              f"frames below floor-0.5%h raw/guarded {(pr < fl-0.005*h).sum()}/"
              f"{(pg < fl-0.005*h).sum()} (deepest raw {(fl-pr.min())/h*100:.2f}%h); "
              f"body offset max {d.max()/h*100:.1f}%h mean {d.mean()/h*100:.1f}%h")
