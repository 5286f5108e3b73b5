"""Hostile reassignments: every attribute of the objects that reach C is replaced with arrays of
the wrong shape or dtype, scalars, None, strings (a seeded pool per attribute), and every public
function is then called on the object. Each group runs in a child process so that a crash is a
failed test and not a dead pytest: the child may raise any Exception, never die of a signal,
and whatever it returns must be sane (finite values of a plausible size, never the 1e277 a read
past the end of a short array gave).

The child prints one line per case before running it (so a crash names the case) and a FAIL
line for every insane result; run one group by hand with
``python bindings/python/tests/test_hostile_inputs.py motion``.
"""
from __future__ import annotations

import os
import pathlib
import pickle
import subprocess
import sys
import tempfile

import numpy as np
import pytest

HERE = pathlib.Path(__file__).resolve()
CLIP = "cmu_01_01_playground_jumps.bvh"
GROUPS = ["motion", "skeleton", "layers", "lgs", "stream", "som", "kmeans", "grbf",
          "primitives"]
LIMIT = 1e12  # larger finite values in a result are garbage (clip units: cm, 40 frames)


# ---- the child ------------------------------------------------------------------------------

def _bad_arrays(a, rng, k=None):
    """Replacements for an array attribute: wrong shapes, dtypes, layouts and types."""
    a = np.asarray(a)
    pool = [("none", None), ("scalar", 1.5), ("string", "rot"), ("list", a.tolist()),
            ("empty", a[:0]), ("extra_dim", a[None]), ("flat", a.reshape(-1)),
            ("float32", a.astype(np.float32)), ("int", a.astype(np.int64)),
            ("bool", a.astype(bool)), ("complex", a.astype(np.complex128)),
            ("object", a.astype(object)), ("strings", np.full(a.shape, "x")),
            ("fortran", np.asfortranarray(a)), ("nan", np.full(a.shape, np.nan)),
            ("random", rng.standard_normal(tuple(int(v) for v in
                                                 rng.integers(0, 6, size=rng.integers(1, 4)))))]
    if a.ndim >= 1 and a.shape[0] > 1:
        # copies, not views: a read past the end of a view would still find the real frames
        pool += [("short", a[: max(1, a.shape[0] // 3)].copy()), ("strided", a[::2]),
                 ("longer", np.concatenate([a, a]))]
    if a.ndim >= 2 and a.size:
        pool += [("drop_col", a[..., :-1]), ("extra_col", np.concatenate([a, a[..., :1]], -1)),
                 ("transposed", a.T), ("2d", a.reshape(a.shape[0], -1))]
    if a.ndim >= 3:
        pool += [("drop_joints", a[:, : max(1, a.shape[1] // 4)]), ("swap12", a.swapaxes(1, 2))]
    if k is not None and len(pool) > k:
        pool = [pool[i] for i in sorted(rng.choice(len(pool), size=k, replace=False))]
    return pool


def _bad_values(v, rng, k=None):
    """Replacements for any attribute, chosen by the kind of its current value."""
    if isinstance(v, np.ndarray) and v.ndim:
        return _bad_arrays(v, rng, k)
    pool = [("none", None), ("string", "x"), ("nan", float("nan")), ("inf", float("inf")),
            ("zero", 0), ("negative", -3), ("huge_int", 10**12), ("tiny", 1e-300),
            ("float_for_int", 2.5), ("array", np.ones((2, 2))), ("list", [1, 2]),
            ("object", object())]
    if k is not None and len(pool) > k:
        pool = [pool[i] for i in sorted(rng.choice(len(pool), size=k, replace=False))]
    return pool


def _insane(x, allow_nan, depth=0):
    """A description of what is wrong with a result, or None."""
    import mlayer
    if depth > 4:
        return None
    if isinstance(x, mlayer.Motion):
        for name in ("root_pos", "rot", "trans"):
            bad = _insane(getattr(x, name), allow_nan, depth + 1)
            if bad:
                return f"Motion.{name}: {bad}"
        return None
    if isinstance(x, np.ndarray):
        if x.dtype.kind not in "fc" or x.size == 0:
            return None
        fin = np.isfinite(x)
        if not allow_nan and not fin.all():
            return f"{(~fin).sum()} non-finite values"
        if fin.any() and np.abs(x[fin]).max() > LIMIT:
            return f"garbage magnitude {np.abs(x[fin]).max():.3g}"
        return None
    if isinstance(x, float):
        return _insane(np.array([x]), allow_nan, depth + 1)
    if isinstance(x, (tuple, list)):
        for y in x[:50]:
            bad = _insane(y, allow_nan, depth + 1)
            if bad:
                return bad
    if isinstance(x, dict):
        return _insane(list(x.values()), allow_nan, depth + 1)
    return None


class _Child:
    def __init__(self):
        self.cases = self.calls = self.raised = 0
        self.fails = []

    def case(self, desc):
        self.cases += 1
        self.desc = desc
        print("CASE", desc, flush=True)

    def call(self, name, fn, allow_nan=False, expect_ok=False):
        self.calls += 1
        try:
            out = fn()
        except Exception as e:  # an exception is the right answer to a hostile input
            self.raised += 1
            if expect_ok:
                line = f"FAIL {self.desc} :: {name} raised on a valid input: {e!r}"
                self.fails.append(line)
                print(line, flush=True)
            return None
        bad = _insane(out, allow_nan)
        if bad:
            line = f"FAIL {self.desc} :: {name}: {bad}"
            self.fails.append(line)
            print(line, flush=True)
        return out

    def calls_on(self, obj, calls, allow_nan=False, expect_ok=False):
        for name, fn in calls:
            self.call(name, lambda fn=fn: fn(obj), allow_nan, expect_ok)


def _clip(n=40):
    import mlayer
    from conftest import mocap_dir
    return mlayer.read_bvh(mocap_dir() / CLIP)[100:100 + n]


def _motion_calls(tmp):
    import mlayer
    from mlayer import metrics
    from mlayer.guards import cleanup, contacts, limits
    from mlayer.manifold import features, generate_guards
    from mlayer.layers import layers
    from mlayer.guards import plausibility
    feet = ["LeftFoot", "RightFoot"]
    return [
        ("positions", lambda m: m.positions()),
        ("forward_kinematics", lambda m: m.forward_kinematics()),
        ("end_site_positions", lambda m: m.end_site_positions()),
        ("local_translations", lambda m: m.local_translations()),
        ("slice", lambda m: m[2:10:2].positions()),
        ("copy", lambda m: m.copy().positions()),
        ("with_frames", lambda m: m.with_frames().positions()),
        ("write_bvh_string", lambda m: mlayer.read_bvh_string(mlayer.write_bvh_string(m))),
        ("write_bvh", lambda m: mlayer.write_bvh(m, os.path.join(tmp, "out.bvh"))),
        ("decompose", lambda m: mlayer.decompose(m).synthesize(2.0)),
        ("denoise", lambda m: mlayer.denoise(m)),
        ("stylize", lambda m: mlayer.stylize(m, 2.0)),
        ("synthesis_guard", lambda m: mlayer.Synthesis(m).guard(m, np.ones(1 + m.n_joints))),
        ("resample", lambda m: mlayer.resample(m, n_frames=60)),
        ("resample_fps", lambda m: mlayer.resample(m, fps=60.0, keep_contacts=False)),
        ("slerp_resample", lambda m: mlayer.slerp_resample(m, n_frames=20)),
        ("timewarp", lambda m: mlayer.timewarp(m, strength=0.5)),
        ("timewarp_speed", lambda m: mlayer.timewarp_speed(m)),
        ("detect_contacts", lambda m: mlayer.detect_contacts(m)),
        ("find_feet", lambda m: contacts.find_feet(m)),
        ("contact_positions", lambda m: contacts.contact_positions(m, feet)),
        ("fix_contacts", lambda m: mlayer.fix_contacts(
            m, np.zeros((m.n_frames, 2), bool), feet, reference=m)),
        ("floor_height", lambda m: cleanup.floor_height(m)),
        ("keep_contacts", lambda m: cleanup.keep_contacts(m, m)),
        ("joint_limits", lambda m: mlayer.joint_limits(m)),
        ("apply_limits", lambda m: limits.apply_limits(m, mlayer.joint_limits(_clip()), 2.0)),
        ("stream_motion", lambda m: mlayer.stream_motion(m, lam=1.0, sigma=1.0, lag=3)),
        ("stream_push", lambda m: mlayer.Stream(m, lam=1.0, sigma=1.0, lag=0).push(m[0])),
        ("jitter", lambda m: metrics.jitter(m)),
        ("body_height", lambda m: metrics.body_height(m)),
        ("mpjpe", lambda m: metrics.mpjpe(m, m)),
        ("foot_sliding", lambda m: metrics.foot_sliding(
            m, np.ones((m.n_frames, 2), bool), feet)),
        ("pose_features", lambda m: features.pose_features(m)),
        ("body_translation_joint", lambda m: layers.body_translation_joint(m)),
        ("guard_motion", lambda m: generate_guards.guard_motion(
            m, feet, np.zeros((m.n_frames, 2), bool), floor=0.0)),
        ("hinge_angles", lambda m: plausibility.hinge_angles(m, mlayer.joint_limits(_clip()))),
        ("repr", lambda m: repr(m)),
        ("pickle", lambda m: pickle.loads(pickle.dumps(m)).positions()),
    ]


def _group_motion(ch, rng, tmp):
    calls = _motion_calls(tmp)
    base = _clip()
    ch.case("motion unchanged")
    ch.calls_on(base, calls, expect_ok=True)  # the calls themselves are right
    for attr in ("root_pos", "rot", "trans", "frame_time", "skeleton"):
        for label, v in _bad_values(getattr(base, attr), rng):
            m = base.copy()
            ch.case(f"Motion.{attr} = {label}")
            try:
                setattr(m, attr, v)
            except Exception:
                pass
            ch.calls_on(m, calls)
    # edits in place, which no setter sees
    # edits in place, which no setter sees; "nan": results may carry the NaN given, "any": the
    # input itself is garbage (float64 bits read as float32), which a function that returns
    # its input unchanged (a skeleton without feet) hands back: only a crash counts
    edits = [("root_pos[5] = nan", lambda m: m.root_pos.__setitem__(5, np.nan), "nan"),
             ("rot[3, 2] = nan", lambda m: m.rot.__setitem__((3, 2), np.nan), "nan"),
             ("rot.shape = (N J, 4)", lambda m: setattr(m.rot, "shape", (-1, 4)), "sane"),
             ("root_pos.shape = (3 N,)", lambda m: setattr(m.root_pos, "shape", (-1,)), "sane"),
             ("rot.dtype = float32", lambda m: setattr(m.rot, "dtype", np.float32), "any"),
             ("trans.shape = (N, 0)", lambda m: setattr(m.trans, "shape", (m.n_frames, 0)),
              "sane")]
    for label, edit, kind in edits:
        m = base.copy()
        ch.case(f"Motion in place: {label}")
        try:
            edit(m)
        except Exception:
            continue
        if kind == "any":
            for _name, fn in calls:
                try:
                    fn(m)
                except Exception:
                    pass
        else:
            ch.calls_on(m, calls, allow_nan=kind == "nan")
    # a motion of another skeleton's frames: the skeleton replaced, arrays kept
    other = _clip()
    sk = other.skeleton
    small = type(sk)(sk.joint_names[:5], sk.parents[:5], sk.offsets[:5])
    m = base.copy()
    ch.case("Motion.skeleton = a 5-joint skeleton")
    m.skeleton = small
    ch.calls_on(m, calls)


def _group_skeleton(ch, rng, tmp):
    calls = _motion_calls(tmp)
    base = _clip()
    sk = base.skeleton
    for attr in type(sk).__slots__:
        for label, v in _bad_values(getattr(sk, attr, None), rng, k=4):
            m = base.copy()
            ch.case(f"Skeleton.{attr} = {label}")
            try:
                setattr(m.skeleton, attr, v)
            except AttributeError:
                continue  # immutable: the right answer; nothing to call
            ch.fails.append(f"FAIL Skeleton.{attr} accepted an assignment")
            ch.calls_on(m, calls[:12])


def _hostile_object(ch, rng, make, attrs, calls, k=None, force=False):
    """For each attribute and each replacement: a fresh object, the assignment (refused or
    not; ``force`` bypasses a frozen dataclass), then every call."""
    obj = make()
    ch.case(f"{type(obj).__name__} unchanged")
    ch.calls_on(obj, calls, expect_ok=True)  # the calls themselves are right
    for attr in attrs:
        obj = make()
        for label, v in _bad_values(getattr(obj, attr, None), rng, k):
            obj = make()
            ch.case(f"{type(obj).__name__}.{attr} = {label}")
            try:
                (object.__setattr__ if force else setattr)(obj, attr, v)
            except Exception:
                pass  # refused: the calls below must still be safe
            ch.calls_on(obj, calls)


def _group_layers(ch, rng, tmp):
    import mlayer
    m = _clip()
    L0 = mlayer.decompose(m)
    calls = [("synthesize", lambda L: L.synthesize(2.0)),
             ("reconstruct", lambda L: L.reconstruct()),
             ("base", lambda L: L.base), ("control", lambda L: L.control),
             ("residual", lambda L: L.residual), ("alphas", lambda L: L.alphas(2.0)),
             ("save_npz", lambda L: L.save_npz(os.path.join(tmp, "l.npz"))),
             ("synthesis", lambda L: mlayer.Synthesis(L.motion, layers=L).run(2.0)),
             ("repr", lambda L: repr(L))]
    attrs = ["motion", "body_joint", "base", "control", "residual", "lam", "sigma", "base_s",
             "base_max_angle", "lam_c", "sigma_c", "control_s", "control_gcv", "control_dof"]
    _hostile_object(ch, rng, lambda: mlayer.Layers(m, L0._h, {
        n: np.array(getattr(L0, n)) for n in mlayer.layers.layers._PARAMS}, L0.body_joint),
        attrs, calls, k=5)
    # the motion the layers keep, edited afterwards
    for attr in ("root_pos", "rot", "trans"):
        for label, v in _bad_values(getattr(m, attr), rng, k=5):
            L = mlayer.decompose(m.copy())
            ch.case(f"Layers.motion.{attr} = {label}")
            try:
                setattr(L.motion, attr, v)
            except Exception:
                pass
            ch.calls_on(L, calls)


def _group_lgs(ch, rng, tmp):
    import copy
    import mlayer
    calls = [("solve", lambda g: g.solve(np.ones(50))),
             ("solve_m", lambda g: g.solve(np.ones((50, 3)))),
             ("solve_out", lambda g: g.solve(np.ones(50), out=np.empty(g.n_out))),
             ("variance", lambda g: g.variance()),
             ("copy", lambda g: copy.copy(g).solve(np.ones(50))),
             ("pickle", lambda g: pickle.loads(pickle.dumps(g)).variance())]
    for t in (None, np.linspace(0, 79, 50)):
        def make(t=t):
            return mlayer.LGS(50 if t is None else 80, 2.0, 1.0, t=t)
        _hostile_object(ch, rng, make, ["n_out", "n_obs", "order", "solver", "lam", "sigma"],
                        calls)


def _group_stream(ch, rng, tmp):
    import mlayer
    m = _clip()
    lim = mlayer.joint_limits(m)
    calls = [("push_tuple", lambda s: s.push((m.root_pos[0], m.rot[0]))),
             ("push_flat", lambda s: s.push(np.zeros(s.frame_size))),
             ("push_motion", lambda s: [s.push(m[i]) for i in range(5)]),
             ("flush", lambda s: s.flush()), ("reset", lambda s: s.reset()),
             ("set_alpha", lambda s: s.set_alpha(2.0)), ("lag", lambda s: s.lag),
             ("pending", lambda s: s.pending), ("alpha", lambda s: s.alpha),
             ("repr", lambda s: repr(s))]
    _hostile_object(ch, rng, lambda: mlayer.Stream(m, lam=1.0, sigma=1.0, lag=3, lam_base=5.0,
                                                   limits=lim),
                    ["skeleton", "lam", "sigma", "lam_base", "sigma_base", "limits"], calls,
                    k=6)


def _group_som(ch, rng, tmp):
    import copy
    import mlayer
    X = rng.standard_normal((60, 4))
    calls = [("train", lambda s: s.train(X, 2)), ("bmu", lambda s: s.bmu(X)),
             ("bmu2", lambda s: s.bmu_index(X, second=True)),
             ("qe", lambda s: s.quantization_error(X)), ("te", lambda s: s.topographic_error(X)),
             ("codebook", lambda s: s.codebook), ("to_bytes", lambda s: s.to_bytes()),
             ("save", lambda s: s.save(os.path.join(tmp, "som.bin"))),
             ("copy", lambda s: copy.deepcopy(s).codebook)]
    _hostile_object(ch, rng, lambda: mlayer.SOM(4, 5, 4).train(X, 2),
                    ["rows", "cols", "dim", "n_threads", "codebook"], calls, k=8)


def _group_kmeans(ch, rng, tmp):
    import mlayer
    X = rng.standard_normal((60, 3))
    res = mlayer.kmeans(X, 4, seed=1)
    _hostile_object(ch, rng, lambda: mlayer.kmeans(X, 4, seed=1),
                    ["centers", "labels", "inertia", "n_iter", "n_skipped"],
                    [("predict", lambda r: r.predict(X))], force=True)
    assert res.predict(X).shape == (60,)


def _group_grbf(ch, rng, tmp):
    import mlayer
    P = rng.uniform(0, 1, (80, 2))
    Y = rng.standard_normal((80, 3))
    calls = [("predict", lambda g: g.predict(P)), ("call", lambda g: g(P[:5])),
             ("design", lambda g: g.design(P)), ("fit", lambda g: g.fit(P, Y).predict(P))]
    for kernel in ("thin_plate", "gaussian"):
        def make(kernel: str = kernel) -> mlayer.GRBF:
            return mlayer.GRBF(kernel, (4, 4)).fit(P, Y)
        attrs = [a for a in vars(make()) if not a.startswith("__")]
        _hostile_object(ch, rng, make, attrs, calls, k=8)


def _group_primitives(ch, rng, tmp):
    import mlayer
    clip = _clip(160)
    model = mlayer.PrimitiveModel.fit([clip], k=3, som=(6, 6), epochs=3, lattice=(5, 5))
    path = os.path.join(tmp, "model.npz")
    model.save(path)
    traj = np.stack([np.linspace(0.5, 4.5, 30), np.linspace(1, 4, 30)], axis=1)
    calls = [("predict", lambda p: p.predict(traj)), ("positions", lambda p: p.positions(traj)),
             ("to_manifold", lambda p: p.to_manifold(clip[:10])),
             ("clamp", lambda p: p.clamp(traj)),
             ("primitive_path", lambda p: p.primitive_path(0, 30)),
             ("spline", lambda p: p.spline(traj[:3], np.array([0.0, 10, 29]), 30)),
             ("generate", lambda p: p.generate(30, seed=1)),
             ("generate_path", lambda p: p.generate(30, path=[0, 1], start_frame=3)),
             ("motion_along", lambda p: p.motion_along(traj)),
             ("contacts_along", lambda p: p.contacts_along(traj)),
             ("training_clips", lambda p: p.training_clips()),
             ("save", lambda p: p.save(os.path.join(tmp, "again.npz")))]
    attrs = [a for a in vars(model) if not a.startswith("_")]
    _hostile_object(ch, rng, lambda: mlayer.PrimitiveModel.load(path), attrs, calls, k=3)


def child(group: str) -> int:
    rng = np.random.default_rng(20240519 + GROUPS.index(group))
    ch = _Child()
    with tempfile.TemporaryDirectory() as tmp:
        globals()[f"_group_{group}"](ch, rng, tmp)
    print(f"DONE {group}: {ch.cases} cases, {ch.calls} calls, {ch.raised} raised, "
          f"{len(ch.fails)} insane", flush=True)
    return 0


# ---- the tests ------------------------------------------------------------------------------

@pytest.mark.parametrize("group", GROUPS)
def test_hostile_group(group, mocap):
    if not (mocap / CLIP).is_file():
        pytest.skip(f"{CLIP} not found")
    env = dict(os.environ, PYTHONFAULTHANDLER="1", MLR_TEST_MOCAP_DIR=str(mocap))
    p = subprocess.run([sys.executable, str(HERE), group], capture_output=True, text=True,
                       timeout=900, env=env, cwd=str(HERE.parent))
    lines = p.stdout.splitlines()
    cases = [ln for ln in lines if ln.startswith("CASE ")]
    assert p.returncode >= 0, (f"{group}: killed by signal {-p.returncode} in "
                               f"{cases[-1] if cases else 'setup'}\n{p.stderr[-3000:]}")
    assert p.returncode == 0, f"{group}: exit {p.returncode}\n{p.stderr[-3000:]}"
    fails = [ln for ln in lines if ln.startswith("FAIL ")]
    assert not fails, "\n".join(fails[:30])
    done = [ln for ln in lines if ln.startswith("DONE ")]
    assert done and len(cases) > 5, p.stdout[-2000:]


if __name__ == "__main__":
    sys.path.insert(0, str(HERE.parent))
    sys.exit(child(sys.argv[1]))
