"""Every public attribute of the package's public classes is read-only or validated where it is
assigned (issue 39, item 5).

For each class, an object is built on a small example and each public attribute (found by
looking at the object: instance attributes, slots, properties, dataclass and NamedTuple
fields) is assigned bad values: None, the wrong type, NaN and infinities, negative and huge
numbers, arrays of the wrong shape, dtype or length. Each assignment must either be refused,
with ``AttributeError`` (read-only) or ``mlayer.InvalidArgumentError`` naming the attribute,
leaving the old value in place, or be harmless: every later call on the object then either
works or raises an mlayer error, never a numpy, cffi or Python one. Valid assignments keep
working and are used.

Run ``python bindings/python/tests/test_public_attributes.py`` for a count of the cases that
fail, per class.
"""
from __future__ import annotations

import copy
import math
import os
import pickle
import sys
import tempfile
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest

import mlayer
from mlayer import metrics
from mlayer.manifold import clustering, mixture
from mlayer.guards import contacts
from mlayer.pipeline import pipeline
from mlayer.model import root_motion
from mlayer.batching import BatchResult
from mlayer.batching.report import FIELDS
from mlayer.layers.one_euro import OneEuroFilter

Call = tuple[str, Callable[[Any], Any]]


# ---- the examples -------------------------------------------------------------------------------

_cache: dict[str, Any] = {}


def _clip() -> mlayer.Motion:
    """60 frames of the bundled walk at 60 fps."""
    if "clip" not in _cache:
        _cache["clip"] = mlayer.data.load_sample()[200:320:2]
    return _cache["clip"].copy()


def _model_path(manifold: str = "som") -> str:
    """A small primitives model, saved once (each case loads its own copy)."""
    key = f"model_{manifold}"
    if key not in _cache:
        m = mlayer.data.load_sample()[:400:2]
        model = mlayer.PrimitiveModel.fit([m], k=3, som=(6, 6), epochs=3, lattice=(5, 5),
                                          manifold=manifold)
        path = os.path.join(_tmp(), f"{key}.npz")
        model.save(path)
        _cache[key] = path
    return _cache[key]


def _data(n: int = 60, d: int = 3) -> np.ndarray:
    return np.random.default_rng(7).standard_normal((n, d))


def _tmp() -> str:
    if "tmp" not in _cache:
        _cache["tmp"] = tempfile.mkdtemp(prefix="mlr_attrs_")
    return _cache["tmp"]


# ---- the classes, their examples and the calls that use them ------------------------------------

def _motion_calls() -> list[Call]:
    return [
        ("positions", lambda m: m.positions()),
        ("slice", lambda m: m[2:10:2].positions()),
        ("copy", lambda m: m.copy().positions()),
        ("fps", lambda m: m.fps),
        ("write_bvh_string", lambda m: mlayer.read_bvh_string(mlayer.write_bvh_string(m))),
        ("resample", lambda m: mlayer.resample(m, fps=30.0, keep_contacts=False)),
        ("slerp_resample", lambda m: mlayer.slerp_resample(m, n_frames=20)),
        ("decompose", lambda m: mlayer.decompose(m).synthesize(2.0)),
        ("detect_contacts", lambda m: mlayer.detect_contacts(m)),
        ("jitter", lambda m: metrics.jitter(m)),
        ("body_height", lambda m: metrics.body_height(m)),
        ("stream_push", lambda m: mlayer.Stream(m, lam=1.0, sigma=1.0, lag=0).push(m[:1])),
        ("write_gltf", lambda m: mlayer.write_gltf(m, os.path.join(_tmp(), "m.glb"))),
        ("up_units", lambda m: (m.up_axis, m.units)),
        ("pickle", lambda m: pickle.loads(pickle.dumps(m)).positions()),
    ]


def _layers_calls() -> list[Call]:
    return [("synthesize", lambda L: L.synthesize(2.0)),
            ("reconstruct", lambda L: L.reconstruct()),
            ("base", lambda L: L.base.positions()), ("control", lambda L: L.control.sum()),
            ("outliers", lambda L: L.outliers.sum()),
            ("outlier_frames", lambda L: L.outlier_frames),
            ("repaired", lambda L: L.repaired().positions()),
            ("alphas", lambda L: L.alphas(2.0)),
            ("save_npz", lambda L: L.save_npz(os.path.join(_tmp(), "l.npz"))),
            ("synthesis", lambda L: mlayer.Synthesis(L.motion, layers=L, floor=None).run(2.0))]


def _stream() -> mlayer.Stream:
    m = _clip()
    return mlayer.Stream(m, lam=1.0, sigma=1.0, lag=3, lam_base=5.0)


def _model(manifold: str = "som") -> mlayer.PrimitiveModel:
    return mlayer.PrimitiveModel.load(_model_path(manifold))


_RECORD = {k: None for k in FIELDS} | {"status": "ok", "input": "a.bvh", "output": "b.bvh"}

_TRAJ = np.stack([np.linspace(0.5, 4.5, 30), np.linspace(1.0, 4.0, 30)], axis=1)


def _model_calls() -> list[Call]:
    traj = _TRAJ
    return [("predict", lambda p: p.predict(traj)), ("positions", lambda p: p.positions(traj)),
            ("to_manifold", lambda p: p.to_manifold(_clip()[:10])),
            ("clamp", lambda p: p.clamp(traj)),
            ("clip_labels", lambda p: p.clip_labels()),
            ("clip_frames", lambda p: p.clip_frames(0)),
            ("primitive_path", lambda p: p.primitive_path(0, 30)),
            ("through", lambda p: p.generate(20, through=[[1, 1], [4, 4]], guards=False)),
            ("generate", lambda p: p.generate(30, seed=1)),
            ("runtime_bytes", lambda p: len(p.runtime_bytes())),
            ("generate_keys", lambda p: p.generate(30, keys=[(0, 3), (0, 50)])),
            ("training_clips", lambda p: p.training_clips()),
            ("joint_limits", lambda p: p.joint_limits()),
            ("save_load", lambda p: (p.save(os.path.join(_tmp(), "m.npz")),
                                     mlayer.PrimitiveModel.load(os.path.join(_tmp(), "m.npz"))
                                     .generate(20, seed=2))),
            ("pickle", lambda p: pickle.loads(pickle.dumps(p)).generate(20, seed=3))]


def _classes() -> dict[str, tuple[Callable[[], Any], list[Call]]]:
    """Class name -> (a new example object, the calls that use it)."""
    X = _data()
    P2 = np.random.default_rng(3).uniform(0, 1, (40, 2))
    Y3 = np.random.default_rng(4).standard_normal((40, 3))
    labels = [np.array([0, 0, 1, 1, 2, 2, 0, 1, 2, 2, 1, 0, 0, 2])]
    pca_calls: list[Call] = [
        ("transform", lambda p: p.transform(X)),
        ("inverse", lambda p: p.inverse_transform(np.ones((4, 2)))),
        ("refit", lambda p: p.fit_transform(X)),
        ("pickle", lambda p: pickle.loads(pickle.dumps(p)).transform(X))]
    grbf_calls: list[Call] = [
        ("predict", lambda g: g.predict(P2)), ("design", lambda g: g.design(P2)),
        ("refit", lambda g: g.fit(P2, Y3).predict(P2)),
        ("pickle", lambda g: pickle.loads(pickle.dumps(g)).predict(P2))]
    gmm_calls: list[Call] = [
        ("predict", lambda g: g.predict(X)), ("proba", lambda g: g.predict_proba(X)),
        ("score", lambda g: g.score(X)), ("bic", lambda g: g.bic(X)),
        ("refit", lambda g: g.fit(X).predict(X))]

    return {
        "Motion": (_clip, _motion_calls()),
        "Skeleton": (lambda: _clip().skeleton,
                     [("motion", lambda s: mlayer.Motion(s, 0.01, np.zeros((2, 3)),
                                                         np.tile([1.0, 0, 0, 0],
                                                                 (2, s.n_joints, 1)))
                       .positions()),
                      ("depth", lambda s: s.depth()), ("repr", lambda s: repr(s))]),
        "Layers": (lambda: mlayer.decompose(_clip()), _layers_calls()),
        "Synthesis": (lambda: mlayer.Synthesis(_clip(), floor=None),
                      [("run", lambda s: s.run(2.0)),
                       ("guard", lambda s: s.guard(s.motion, np.ones(1 + s.motion.n_joints)))]),
        "GuardReport": (lambda: mlayer.Synthesis(_clip()).run(2.0)[1],
                        [("repr", lambda r: repr(r))]),
        "LGS": (lambda: mlayer.LGS(30, 2.0, 1.0),
                [("solve", lambda g: g.solve(np.ones(30))), ("variance", lambda g: g.variance()),
                 ("copy", lambda g: copy.copy(g).solve(np.ones(30)))]),
        "Stream": (_stream,
                   [("push", lambda s: [s.push(_clip()[i]) for i in range(5)]),
                    ("flush", lambda s: s.flush()), ("set_alpha", lambda s: s.set_alpha(2.0)),
                    ("lag", lambda s: s.lag), ("repr", lambda s: repr(s))]),
        "JointLimits": (lambda: mlayer.joint_limits(_clip()),
                        [("range", lambda j: j.range(1)),
                         ("apply", lambda j: mlayer.guards.limits.apply_limits(_clip(), j, 2.0))]),
        "SOM": (lambda: mlayer.SOM(3, 4, 3).train(X, 2),
                [("train", lambda s: s.train(X, 2)), ("bmu", lambda s: s.bmu(X)),
                 ("qe", lambda s: s.quantization_error(X)),
                 ("te", lambda s: s.topographic_error(X)), ("codebook", lambda s: s.codebook),
                 ("copy", lambda s: copy.deepcopy(s).bmu(X)),
                 ("pickle", lambda s: pickle.loads(pickle.dumps(s)).bmu(X))]),
        "KMeansResult": (lambda: mlayer.kmeans(X, 3, seed=1),
                         [("predict", lambda r: r.predict(X))]),
        "ElbowResult": (lambda: mlayer.elbow(X, range(2, 5), seed=1),
                        [("repr", lambda r: repr(r))]),
        "FuzzyResult": (lambda: mixture.fuzzy_cmeans(X, 3, seed=1),
                        [("repr", lambda r: repr(r))]),
        "KCriteria": (lambda: mixture.k_criteria(X, [2, 3], seed=1),
                      [("repr", lambda r: repr(r))]),
        "PCA": (lambda: mlayer.PCA(2).fit(X), pca_calls),
        "PCA:unfitted": (lambda: mlayer.PCA(2), pca_calls),
        "GRBF": (lambda: mlayer.GRBF("gaussian", (4, 4)).fit(P2, Y3), grbf_calls),
        "GRBF:unfitted": (lambda: mlayer.GRBF("thin_plate", (4, 4)), grbf_calls),
        "GaussianMixture": (lambda: mlayer.GaussianMixture(2, seed=1).fit(X), gmm_calls),
        "GaussianMixture:unfitted": (lambda: mlayer.GaussianMixture(2, seed=1), gmm_calls),
        "Rng": (lambda: mlayer.manifold.markov.Rng(5),
                [("below", lambda r: r.below(10)), ("uniform", lambda r: r.uniform())]),
        "Markov": (lambda: mlayer.Markov.fit(labels, order=2),
                   [("sample", lambda k: k.sample(0, 20, seed=1)),
                    ("sample_distinct", lambda k: k.sample(0, 10, seed=1, distinct=True)),
                    ("perturbed", lambda k: k.perturbed(0.1, 1).sample(0, 10, seed=1)),
                    ("ranked_next", lambda k: k.ranked_next([0, 1], 1)),
                    ("walk", lambda k: k.walk(0, 20, seed=1)),
                    ("next", lambda k: k.next_distribution([0, 1])),
                    ("path", lambda k: k.most_likely_path(0, 5)),
                    ("stationary", lambda k: k.stationary()),
                    ("context_arrays", lambda k: k.context_arrays())]),
        "PrimitiveModel": (_model, _model_calls()),
        "PrimitiveModel:pca": (lambda: _model("pca"), _model_calls()),
        "RootTrack": (lambda: mlayer.extract_root_motion(_clip())[1],
                      [("apply", lambda t: t.apply(mlayer.extract_root_motion(_clip())[0])),
                       ("repr", lambda t: repr(t)),
                       ("csv", lambda t: t.to_csv(os.path.join(_tmp(), "root.csv")))]),
        "OneEuroFilter": (lambda: OneEuroFilter(30.0, 1.0, 0.1),
                          [("filter", lambda f: [f(np.ones(3) * i) for i in range(4)])]),
        "Clip": (lambda: pipeline.Clip(_clip(), name="walk"),
                 [("positions", lambda c: c.positions), ("up", lambda c: c.up),
                  ("body_height", lambda c: c.body_height), ("contacts", lambda c: c.contacts),
                  ("synthesis", lambda c: c.synthesis(floor=None).run(2.0))]),
        "UpGuess": (lambda: mlayer.detect_up(_clip()), [("repr", lambda g: repr(g))]),
        "LeadIn": (lambda: mlayer.lead_in(_clip()), [("repr", lambda g: repr(g))]),
        "AlphaCurve": (lambda: mlayer.AlphaCurve([(0.0, 1.0), (0.5, 3.0), (1.0, 1.0)]),
                       [("call", lambda c: c(np.linspace(-1.0, 2.0, 7))),
                        ("sample", lambda c: c.sample(10, 30.0))]),
        "BatchResult": (lambda: BatchResult("denoise", [dict(_RECORD)], 1.5, 1),
                        [("table", lambda r: r.table()), ("exit_code", lambda r: r.exit_code),
                         ("report", lambda r: r.write_report(os.path.join(_tmp(), "r.csv")))]),
        "Frame": (lambda: mlayer.Stream(_clip(), lam=1.0, sigma=1.0, lag=0).push(
                      (_clip().root_pos[0], _clip().rot[0])),
                  [("repr", lambda g: repr(g))]),
    }


# ---- the bad values -----------------------------------------------------------------------------

def _bad_scalars() -> list[tuple[str, Any]]:
    return [("None", None), ("str", "x"), ("object", object()), ("nan", math.nan),
            ("inf", math.inf), ("-inf", -math.inf), ("negative", -3), ("zero", 0),
            ("huge", 1e308), ("-huge", -1e308), ("float_for_int", 2.5), ("bool", True),
            ("big_int", 10**12), ("array", np.ones((2, 2))), ("list", [1, 2]),
            ("tuple", (1.0, 2.0)), ("dict", {"a": 1})]


def _bad_arrays(a: np.ndarray) -> list[tuple[str, Any]]:
    out: list[tuple[str, Any]] = [("empty", a[:0]), ("extra_dim", a[None]),
                                  ("flat", a.reshape(-1)), ("strings", np.full(a.shape, "x")),
                                  ("object", a.astype(object)), ("complex", a.astype(complex))]
    if a.dtype.kind in "fiu" and a.size:
        out += [("nan", np.full(a.shape, np.nan)), ("inf", np.full(a.shape, np.inf)),
                ("huge", np.full(a.shape, 1e308)), ("negative", np.full(a.shape, -3)),
                ("bool", a.astype(bool)), ("float_for_int", a + 0.5)]
    if a.ndim >= 1 and a.shape[0] > 1:
        out += [("short", a[: a.shape[0] // 2].copy()), ("longer", np.concatenate([a, a]))]
    if a.ndim >= 2 and a.size:
        out += [("drop_col", a[..., :-1].copy()),
                ("extra_col", np.concatenate([a, a[..., :1]], -1)), ("transposed", a.T)]
    return out


def _bad_values(current: Any) -> list[tuple[str, Any]]:
    vals = _bad_scalars()
    if isinstance(current, np.ndarray) and current.ndim:
        vals += _bad_arrays(current)
    return vals


# ---- the checks ---------------------------------------------------------------------------------

def public_attributes(obj: Any) -> list[str]:
    """The public data attributes of obj: what it holds and the class's properties (cached
    ones too), fields and slots, not its methods or nested classes."""
    import inspect
    import types
    methods = (classmethod, staticmethod, types.FunctionType, types.BuiltinFunctionType,
               types.MethodDescriptorType, types.WrapperDescriptorType,
               types.MethodWrapperType, type)
    names = []
    for n in dir(obj):
        if n.startswith("_"):
            continue
        try:
            static = inspect.getattr_static(obj, n)
        except AttributeError:
            continue
        if not isinstance(static, methods):
            names.append(n)
    return names


def _same(a: Any, b: Any) -> bool:
    if a is b:
        return True
    if isinstance(a, AttributeError) and isinstance(b, AttributeError):
        return True  # was not set and is not
    if isinstance(a, (tuple, list)) and isinstance(b, (tuple, list)):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    try:
        if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
            return bool(np.array_equal(a, b, equal_nan=True))
        return bool(a == b) or (isinstance(a, float) and isinstance(b, float)
                                and math.isnan(a) and math.isnan(b))
    except Exception:
        return False


def _get(obj: Any, name: str) -> Any:
    try:
        return getattr(obj, name)
    except Exception as e:  # an attribute may raise (a closed handle): not the case here
        return e


def _finite(x: Any, depth: int = 0) -> bool:
    """Whether a result holds no NaN or infinity (in its arrays, floats, Motions, tuples)."""
    if depth > 3:
        return True
    if isinstance(x, mlayer.Motion):
        return all(_finite(getattr(x, n), depth + 1) for n in ("root_pos", "rot", "trans"))
    if isinstance(x, np.ndarray) and x.dtype.kind in "fc":
        return bool(np.isfinite(x).all())
    if isinstance(x, float):
        return math.isfinite(x)
    if isinstance(x, (tuple, list)):
        return all(_finite(y, depth + 1) for y in x[:20])
    if isinstance(x, dict):
        return all(_finite(y, depth + 1) for y in list(x.values())[:20])
    return True


def check_class(name: str, limit: int | None = None) -> tuple[int, list[str]]:
    """(cases, failures) of the bad assignments to every public attribute of a class."""
    make, calls = _classes()[name]
    fails: list[str] = []
    cases = 0
    # the calls on an untouched object: these give finite results
    finite_before = set()
    for call, fn in calls:
        try:
            out = fn(make())
        except mlayer.Error:  # an unfitted model
            continue
        if _finite(out):
            finite_before.add(call)
    attrs = public_attributes(make())
    if ":unfitted" in name:  # the attributes a fit sets too
        attrs = sorted(set(attrs) | set(public_attributes(_classes()[name.split(":")[0]][0]())))
    assert attrs, f"{name}: no public attributes found"
    fitted = _classes()[name.split(":")[0]][0]
    for attr in attrs:
        probe = fitted()  # (an unfitted object's attributes take the fitted one's bad values)
        for label, value in _bad_values(_get(probe, attr)):
            cases += 1
            obj = make()
            old = _get(obj, attr)
            case = f"{name}.{attr} = {label}"
            try:
                setattr(obj, attr, value)
            except AttributeError:
                if not _same(_get(obj, attr), old):
                    fails.append(f"{case}: refused, but the value changed")
                continue
            except mlayer.InvalidArgumentError as e:
                if attr not in str(e):
                    fails.append(f"{case}: the message does not name {attr}: {e}")
                if not _same(_get(obj, attr), old):
                    fails.append(f"{case}: refused, but the value changed")
                continue
            except Exception as e:
                fails.append(f"{case}: the assignment raised {type(e).__name__}: {e}")
                continue
            for call, fn in calls:
                try:
                    out = fn(obj)
                except mlayer.Error:
                    continue
                except Exception as e:
                    fails.append(f"{case}: then {call} raised {type(e).__name__}: "
                                 f"{str(e)[:120]}")
                    continue
                if call in finite_before and not _finite(out):
                    fails.append(f"{case}: then {call} gave NaN or infinite values")
            if limit is not None and len(fails) > limit:
                return cases, fails
    return cases, fails


CLASSES = ["Motion", "Skeleton", "Layers", "Synthesis", "GuardReport", "LGS", "Stream",
           "JointLimits", "SOM", "KMeansResult", "ElbowResult", "FuzzyResult", "KCriteria",
           "PCA", "PCA:unfitted", "GRBF", "GRBF:unfitted", "GaussianMixture",
           "GaussianMixture:unfitted", "Markov", "Rng", "PrimitiveModel", "PrimitiveModel:pca",
           "RootTrack", "OneEuroFilter", "Clip", "UpGuess", "LeadIn", "Frame", "BatchResult",
           "AlphaCurve"]


# ---- the tests ----------------------------------------------------------------------------------

def test_every_class_is_listed():
    """The public classes of mlayer and its modules are all in CLASSES (a new class needs an
    example here)."""
    import inspect
    seen = set()
    for mod in [mlayer, clustering, contacts, mixture, pipeline, root_motion,
                mlayer.manifold.manifold, mlayer.manifold.markov, mlayer.manifold.som,
                mlayer.pipeline.stream, mlayer.guards.limits, mlayer.layers.layers,
                mlayer.model.motion, mlayer.layers.smoothing, mlayer.manifold.primitives,
                mlayer.layers.one_euro, mlayer.model.up_axis, mlayer.model.trimming,
                mlayer.batching]:
        for n in getattr(mod, "__all__", []):
            v = getattr(mod, n)
            if inspect.isclass(v) and not issubclass(v, BaseException):
                seen.add(v.__name__)
    assert seen - {"ScipyFrames", "Operation"} <= set(CLASSES), sorted(seen - set(CLASSES))
    assert set(CLASSES) == set(_classes())


@pytest.mark.filterwarnings("ignore")  # the bad values provoke numpy's and mlayer's warnings
@pytest.mark.parametrize("name", CLASSES)
def test_bad_assignments(name):
    cases, fails = check_class(name, limit=40)
    assert cases > 0
    assert not fails, f"{len(fails)} of {cases} cases:\n" + "\n".join(fails[:40])


def _positions_differ(a: mlayer.Motion, b: mlayer.Motion) -> bool:
    return not np.allclose(a.positions(), b.positions())


def test_valid_assignments_are_used():
    m = _clip()
    m.frame_time = 0.02
    assert m.fps == pytest.approx(50.0)
    assert mlayer.resample(m, fps=25.0, keep_contacts=False).n_frames == 30
    m.root_pos = m.root_pos + 1.0
    np.testing.assert_allclose(m.positions()[:, 0], _clip().positions()[:, 0] + 1.0)
    m.up_axis, m.units = "y", "cm"
    assert (m.up_axis, m.units) == ("y", "cm")

    model = _model()
    model.frame_time = model.frame_time / 2
    assert model.generate(20, seed=1).frame_time == pytest.approx(model.frame_time)
    model.floor_height = 3.0
    assert model.floor_height == 3.0
    names = [f"c{i}" for i in range(len(model.clip_starts))]
    model.clip_names = names
    assert model.clip_frames("c0") == model.clip_frames(0)
    model.markov = model.markov.perturbed(0.5, 1)
    assert model.primitive_path(0, 30).max() < model.centers.shape[0]

    f = OneEuroFilter(30.0, 1.0, 0.0)
    f(np.zeros(2))
    slow = f(np.ones(2)).copy()
    g = OneEuroFilter(30.0, 1.0, 0.0)
    g(np.zeros(2))
    g.min_cutoff = 10.0  # a faster filter follows the step further
    assert (g(np.ones(2)) > slow).all()

    s = mlayer.SOM(3, 4, 3).train(_data(), 2)
    w = np.zeros((3, 4, 3))
    w[1, 2] = 1.0
    s.codebook = w
    assert s.bmu_index(np.ones((1, 3)))[0] == 1 * 4 + 2

    grbf = mlayer.GRBF("gaussian", (4, 4))
    grbf.n_threads = 1
    assert grbf.n_threads == 1

    mk = mlayer.Markov.fit([np.array([0, 0, 1, 1, 2, 2, 0, 1, 2, 2, 1, 0, 0, 2])], order=2)
    mk.min_count = 2
    assert mk.min_count == 2

    c = pipeline.Clip(_clip())
    c.name = "renamed"
    assert c.name == "renamed"


def test_frame_time_range():
    """A frame time is 1e-6 .. 1e6 s wherever it enters: frame_time = 1e308 made the clip's
    duration infinite (write_gltf then failed with a ValueError of json)."""
    import re
    m = _clip()
    for bad in (1e308, 1e7, math.inf, True):
        with pytest.raises(mlayer.InvalidArgumentError, match="Motion.frame_time"):
            m.frame_time = bad
        with pytest.raises(mlayer.InvalidArgumentError, match="frame_time"):
            mlayer.Motion(m.skeleton, bad, m.root_pos, m.rot)
    assert m.frame_time == _clip().frame_time
    m.frame_time = 1e6  # the largest
    mlayer.write_gltf(m, os.path.join(_tmp(), "slow.glb"))
    text = re.sub(r"Frame Time:.*", "Frame Time: 1e308", mlayer.write_bvh_string(_clip()))
    with pytest.raises(mlayer.ParseError, match="Frame Time 1e\\+308 s is above"):
        mlayer.read_bvh_string(text)


def test_refused_values_name_the_attribute():
    model = _model()
    with pytest.raises(AttributeError, match="PrimitiveModel.points is read-only"):
        model.points = model.points[:5]
    with pytest.raises(mlayer.InvalidArgumentError, match="PrimitiveModel.frame_time"):
        model.frame_time = 1e308
    with pytest.raises(mlayer.InvalidArgumentError, match="PrimitiveModel.markov must have"):
        model.markov = mlayer.Markov(np.eye(2))
    L = mlayer.decompose(_clip())
    with pytest.raises(AttributeError, match="Layers.outliers is read-only"):
        L.outliers = None
    assert L.outliers.shape == (60, 1 + L.motion.n_joints)
    pca = mlayer.PCA(2)  # not fitted yet: the fitted attributes are read-only all the same
    with pytest.raises(AttributeError, match="read-only"):
        pca.components_ = np.eye(3)[:2]


if __name__ == "__main__":
    total_cases = total_failed = 0
    for cls_name in (sys.argv[1:] or CLASSES):
        n, bad = check_class(cls_name)
        failed = len({line.split(": ")[0] for line in bad})
        total_cases += n
        total_failed += failed
        print(f"{cls_name}: {failed} of {n} cases fail ({len(bad)} failures)", flush=True)
        for line in bad[:int(os.environ.get("SHOW", "0"))]:
            print("   ", line)
    print(f"total: {total_failed} of {total_cases} cases fail")
