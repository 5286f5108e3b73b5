"""Objects owning C handles: copies, pickles and closed objects (issue: a copy.copy of an LGS,
Stream or SOM shared the handle, and closing one left the other on freed memory).

Each check runs in a child process (``python test_handles.py NAME``): a use after free that
crashes fails the test instead of killing pytest. The child prints OK at the end.
"""
from __future__ import annotations

import copy
import gc
import os
import pathlib
import pickle
import subprocess
import sys

import numpy as np
import pytest

HERE = pathlib.Path(__file__).resolve()
CLIP = "cmu_01_01_playground_jumps.bvh"


def _raises(exc, fn, match=None):
    try:
        fn()
    except exc as e:
        assert match is None or match in str(e), f"{e!r} lacks {match!r}"
        return
    raise AssertionError(f"{fn} did not raise {exc.__name__}")


def _clip(n=60):
    import mlayer
    from conftest import mocap_dir
    return mlayer.read_bvh(mocap_dir() / CLIP)[100:100 + n]


def check_lgs():
    import mlayer
    t = np.linspace(0, 79, 50)
    y = np.random.default_rng(1).standard_normal((50, 3))
    g = mlayer.LGS(80, 2.0, 0.5, t=t)
    want, var = g.solve(y), g.variance()
    copies = [copy.copy(g), copy.deepcopy(g), pickle.loads(pickle.dumps(g))]
    g.close()
    assert g.closed
    for c in copies:  # independent handles: the original's close leaves them working
        assert c._h is not None and not c.closed
        np.testing.assert_array_equal(c.solve(y), want)
        np.testing.assert_array_equal(c.variance(), var)
        assert (c.n_out, c.n_obs, c.lam, c.sigma) == (80, 50, 2.0, 0.5)
    for fn in (lambda: g.solve(y), g.variance, lambda: copy.copy(g), lambda: pickle.dumps(g)):
        _raises(mlayer.InvalidArgumentError, fn, "closed")
    with mlayer.LGS(10) as h:
        h.solve(np.ones(10))
    _raises(mlayer.InvalidArgumentError, lambda: h.solve(np.ones(10)), "closed")
    _raises(AttributeError, lambda: setattr(copies[0], "n_out", 10**6), "read-only")
    g.close()  # twice: harmless


def check_som():
    import mlayer
    X = np.random.default_rng(2).standard_normal((80, 3))
    s = mlayer.SOM(4, 5, 3, seed=3, sigma1=0.5).train(X, 3)
    cb, bmu = s.codebook, s.bmu_index(X)
    copies = [copy.copy(s), copy.deepcopy(s), pickle.loads(pickle.dumps(s))]
    s.close()
    for c in copies:
        np.testing.assert_array_equal(c.codebook, cb)
        np.testing.assert_array_equal(c.bmu_index(X), bmu)
        assert c._options["sigma1"] == 0.5
    copies[0].train(X, 2)  # training one copy leaves the others alone
    assert not np.array_equal(copies[0].codebook, cb)
    np.testing.assert_array_equal(copies[1].codebook, cb)
    for fn in (lambda: s.codebook, lambda: s.train(X, 1), lambda: s.bmu(X), s.to_bytes,
               lambda: s.quantization_error(X), lambda: copy.deepcopy(s)):
        _raises(mlayer.InvalidArgumentError, fn, "closed")
    _raises(AttributeError, lambda: setattr(copies[0], "rows", 100), "read-only")


def check_stream():
    import mlayer
    m = _clip()
    st = mlayer.Stream(m, lam=1.0, sigma=1.0, lag=3, lam_base=4.0)
    st.push(m[0])
    for fn in (lambda: copy.copy(st), lambda: copy.deepcopy(st), lambda: pickle.dumps(st)):
        _raises(TypeError, fn, "C handle")
    st.close()
    for fn in (lambda: st.push(m[1]), st.flush, st.reset, lambda: st.lag, lambda: st.pending,
               lambda: st.n_pushed, lambda: st.set_alpha(2.0), lambda: repr(st),
               lambda: copy.copy(st)):
        _raises(mlayer.InvalidArgumentError, fn, "closed")
    lim = mlayer.joint_limits(m)
    st = mlayer.Stream(m, lam=1.0, sigma=1.0, lag=2, limits=lim)
    _raises(AttributeError, lambda: setattr(st, "limits", None), "read-only")
    del lim
    gc.collect()  # the stream keeps the limits it borrows
    assert all(st.push(m[i]) is None for i in range(2)) and st.push(m[2]) is not None


def check_joint_limits():
    import mlayer
    lim = mlayer.joint_limits(_clip())
    for fn in (lambda: copy.copy(lim), lambda: copy.deepcopy(lim), lambda: pickle.dumps(lim)):
        _raises(TypeError, fn, "joint_limits")
    names = lim.joint_names
    names.append("extra")  # a copy: the model's names cannot be edited
    assert lim.n_joints == len(names) - 1


def check_layers_and_synthesis():
    import mlayer
    m = _clip()
    L = mlayer.decompose(m)
    want = L.synthesize(2.0)
    shallow, deep = copy.copy(L), copy.deepcopy(L)
    assert deep.motion is not L.motion and shallow.motion is L.motion
    del L
    gc.collect()  # the handle lives as long as a copy uses it
    for c in (shallow, deep):
        np.testing.assert_array_equal(c.synthesize(2.0).rot, want.rot)
    _raises(TypeError, lambda: pickle.dumps(shallow), "save_npz")
    _raises(AttributeError, lambda: setattr(shallow, "motion", m[:10]), "read-only")
    s = mlayer.Synthesis(m, layers=shallow)
    out, _ = s.run(2.0)
    s2 = copy.copy(s)
    del s
    gc.collect()
    np.testing.assert_array_equal(s2.run(2.0)[0].rot, out.rot)
    _raises(TypeError, lambda: copy.deepcopy(s2), "Synthesis")
    _raises(TypeError, lambda: pickle.dumps(s2), "Synthesis")
    # a synthesis of other frames cannot reach the guards, which read the input's frame count
    _raises(mlayer.InvalidArgumentError, lambda: s2.guard(out[:20], np.ones(1 + m.n_joints)),
            "synthesized")


def check_plain_data():
    import mlayer
    m = _clip()
    for c in (copy.copy(m), copy.deepcopy(m), pickle.loads(pickle.dumps(m))):
        np.testing.assert_array_equal(c.positions(), m.positions())
        assert c.skeleton == m.skeleton
    sk = pickle.loads(pickle.dumps(m.skeleton))
    _raises(AttributeError, lambda: setattr(sk, "parents", sk.parents[:3]), "read-only")
    model = mlayer.PrimitiveModel.fit([_clip(160)], k=3, som=(5, 5), epochs=2, lattice=(4, 4))
    model.joint_limits()  # a cached C model: left out of copies and pickles, made again
    for c in (copy.copy(model), copy.deepcopy(model), pickle.loads(pickle.dumps(model))):
        assert "_limits_cache" not in vars(c)
        np.testing.assert_allclose(c.positions(model.points[:5]),
                                   model.positions(model.points[:5]))
        assert c.joint_limits().n_joints == m.n_joints


CHECKS = ["lgs", "som", "stream", "joint_limits", "layers_and_synthesis", "plain_data"]


@pytest.mark.parametrize("name", CHECKS)
def test_handles_in_child(name, mocap):
    env = dict(os.environ, PYTHONFAULTHANDLER="1", MLR_TEST_MOCAP_DIR=str(mocap))
    p = subprocess.run([sys.executable, str(HERE), name], capture_output=True, text=True,
                       timeout=600, env=env, cwd=str(HERE.parent))
    assert p.returncode >= 0, f"{name}: killed by signal {-p.returncode}\n{p.stderr[-3000:]}"
    assert p.returncode == 0 and p.stdout.strip().endswith("OK"), p.stderr[-3000:]


if __name__ == "__main__":
    sys.path.insert(0, str(HERE.parent))
    globals()[f"check_{sys.argv[1]}"]()
    print("OK")
