"""mlr_pipeline (include/mlayer/mlr_pipeline.h), the C job object, against the steps it composes.

The reference below is mlayer's Python pipeline as it was before it called mlr_pipeline: the
up axis and body height of mlayer.Motion, the options of mlayer.decompose, the repaired input,
the guards' options of mlayer.Synthesis, the synthesis with the body translation where it
rides, mlr_guards_apply_trans. The C pipeline, and mlayer.stylize / mlayer.denoise (which now
call it), must give the same motion to 1e-9 of the body height on the shared clips (Bandai's
static root, the dog, 25 to 120 fps) and the Z-up clips of tests/data/wild.
"""
import fnmatch
import math

import numpy as np
import pytest

import mlayer
from conftest import REPO, mocap_dir
from mlayer import _arrays
from mlayer._native import ffi, lib
from mlayer.model._rig import c_rig
from mlayer.errors import check
from mlayer.layers.layers import body_translation_joint
from mlayer.guards.metrics import body_height

SHARED = ["cmu_131_01_mj_style_walk.bvh", "bandai1_walk_happy_001.bvh",
          "cmu_01_01_playground_jumps.bvh", "cmu_10_01_soccer_kick.bvh",
          "cmu_60_10_salsa_dance.bvh", "cmu_02_03_run_jog_25fps.bvh",
          "ai4a_dog_D1_008_KAN01_002.bvh", "lafan1_clip_a.bvh"]
ZUP = ["makehuman_walk1_zup.bvh", "fair1_jumping_zup_first400.bvh"]
CLIPS = [f"shared/{n}" for n in SHARED] + [f"wild/{n}" for n in ZUP]
#: the largest difference allowed, in body heights (and radians-free quaternion units)
TOL = 1e-9


def _read(name):
    if name.startswith("shared/"):
        p = mocap_dir() / name[len("shared/"):]
        if not p.is_file():
            pytest.skip(f"shared clip not found: {p}")
    else:
        p = REPO / "tests" / "data" / name
    return mlayer.read_bvh(p)


def _point_heights(m, root, rot, trans, up):
    """(N, J + E) heights along up of every joint and End Site of m's skeleton moved so."""
    x = m.with_frames(root_pos=root, rot=rot, trans=trans)
    return np.concatenate([x.positions()[..., up], x.end_site_positions()[..., up]], axis=1)


def _reference(m, alpha, joints=None):
    """The motion mlayer.stylize gave before it called mlr_pipeline (see the module doc)."""
    J, sk = m.n_joints, m.skeleton
    up = "xyz".index(m.up_axis)  # given, or detected (Y when unsure)
    h = body_height(m.positions(), up=m.up_axis)
    body = body_translation_joint(m)
    root, rot, trans = m._frames()
    col = int(np.flatnonzero(sk.trans_joints == body)[0]) if body else None
    t = np.ascontiguousarray(root if body == 0 else trans[:, col])
    opts = [(lib.MLR_LAYERS_OPT_GAMMA, math.pi / 2), (lib.MLR_LAYERS_OPT_FPS, m.fps),
            (lib.MLR_LAYERS_OPT_BASE_CUTOFF, 0.25), (lib.MLR_LAYERS_OPT_ROBUST, 1.0),
            (lib.MLR_LAYERS_OPT_BODY_HEIGHT, h)]
    if body:
        opts.append((lib.MLR_LAYERS_OPT_BODY_JOINT, float(body)))
    copts = ffi.new("mlr_layers_option[]", len(opts))
    for k, (key, v) in enumerate(opts):
        copts[k].key, copts[k].value = key, v
    out = ffi.new("mlr_layers **")
    diag = ffi.new("mlr_diag *")
    check(lib.mlr_layers_decompose(m.n_frames, J, _arrays.ptr(t), _arrays.ptr(rot), copts,
                                   len(opts), ffi.NULL, out, diag), "decompose", diag)
    L = ffi.gc(out[0], lib.mlr_layers_destroy)
    N = m.n_frames
    # the guards learn from the input with its outlier frames repaired
    rt, rq, rtr = t.copy(), rot.copy(), trans.copy()
    check(lib.mlr_layers_repair(L, 0, N, _arrays.ptr_out(rt), rt.size, _arrays.ptr_out(rq),
                                rq.size, ffi.NULL, diag), "repair", diag)
    rr = root.copy()
    if body:
        rtr[:, col] = rt
    else:
        rr = rt
    gopts = [(lib.MLR_GUARDS_OPT_UP, up), (lib.MLR_GUARDS_OPT_LIMITS, lib.MLR_GUARDS_LIMITS_AUTO),
             (lib.MLR_GUARDS_OPT_KEEP_CONTACTS, 1.0), (lib.MLR_GUARDS_OPT_FLOOR, 1.0)]
    cg = ffi.new("mlr_guards_option[]", len(gopts))
    for k, (key, v) in enumerate(gopts):
        cg[k].key, cg[k].value = key, v
    rig, keep = c_rig(sk)
    gout = ffi.new("mlr_guards **")
    check(lib.mlr_guards_create(rig, m.fps, N, _arrays.ptr(rr), _arrays.ptr(rq),
                                _arrays.ptr(rtr) if rtr.size else ffi.NULL, cg, len(gopts),
                                ffi.NULL, gout, diag), "guards", diag)
    G = ffi.gc(gout[0], lib.mlr_guards_destroy)
    # the alphas, the synthesis, the guards
    a = np.full(1 + J, float(alpha))
    for pattern, v in (joints or {}).items():
        a[1 + np.array([k for k, n in enumerate(m.joint_names)
                        if fnmatch.fnmatchcase(n, pattern)], dtype=int)] = v
    st, q = np.empty((N, 3)), np.empty((N, J, 4))
    check(lib.mlr_layers_synthesize(L, 0, N, _arrays.ptr(a), a.size, _arrays.ptr_out(st),
                                    st.size, _arrays.ptr_out(q), q.size, diag), "synth", diag)
    r, tr = root.copy(), trans.copy()
    if body:
        tr[:, col] = st
    else:
        r = st
    rep = ffi.new("mlr_guards_report *")
    check(lib.mlr_guards_apply_trans(G, _arrays.ptr(a), a.size, ffi.NULL, ffi.NULL, ffi.NULL,
                                     _arrays.ptr_out(r), _arrays.ptr_out(q),
                                     _arrays.ptr_out(tr) if tr.size else ffi.NULL, ffi.NULL, 0,
                                     rep, diag), "guards apply", diag)
    # the runs at the ends that the layers left out: as they are in a denoise, else the
    # result's pose next to the run held over it
    head, tail = ffi.new("size_t *"), ffi.new("size_t *")
    check(lib.mlr_layers_get_end_runs(L, head, tail), "end runs")
    for sl, nxt in ((slice(0, head[0]), head[0]), (slice(N - tail[0], N), N - tail[0] - 1)):
        if np.all(a == 1.0):
            r[sl], q[sl], tr[sl] = root[sl], rot[sl], trans[sl]
        elif sl.stop > sl.start:
            r[sl], q[sl], tr[sl] = r[nxt], q[nxt], tr[nxt]
            if math.isfinite(rep.floor_height):  # raised where deeper than the input
                held, inp = (_point_heights(m, r, q, tr, up)[sl],
                             _point_heights(m, root, rot, trans, up)[sl])
                f = rep.floor_height
                need = (np.maximum(0.0, f - held) - np.maximum(0.0, f - inp)).max(axis=1)
                r[sl, up] += max(need.max(), 0.0)  # one lift over the run
    del keep
    return r, q, tr, h


def _c_run(m, alpha, joints=None, **params):
    """mlr_pipeline_run through cffi on a copy of m: (root_pos, rot, trans, the pipeline)."""
    diag = ffi.new("mlr_diag *")
    pp = ffi.new("mlr_pipeline **")
    check(lib.mlr_pipeline_create(ffi.NULL, pp, diag), "create", diag)
    p = ffi.gc(pp[0], lib.mlr_pipeline_destroy)
    check(lib.mlr_pipeline_set(p, lib.MLR_PIPELINE_ALPHA, alpha, diag), "alpha", diag)
    for key, v in params.items():
        check(lib.mlr_pipeline_set(p, getattr(lib, "MLR_PIPELINE_" + key.upper()), v, diag),
              key, diag)
    for pattern, v in (joints or {}).items():
        check(lib.mlr_pipeline_set_joint_alpha(p, pattern.encode(), v, diag), pattern, diag)
    h = m._handle()
    out = ffi.new("mlr_motion **")
    check(lib.mlr_pipeline_run(p, h.ptr, out, diag), "run", diag)
    res = mlayer.Motion._adopt_c(out[0])
    return res.root_pos, res.rot, res.trans, p


def _diff(a, b, h):
    """max |a - b| of the translations in body heights and of the quaternions."""
    (r1, q1, t1), (r2, q2, t2) = a, b
    dt = max(np.abs(r1 - r2).max(), np.abs(t1 - t2).max() if t1.size else 0.0) / h
    return dt, float(np.abs(q1 - q2).max())


CASES = [(1.0, None), (2.5, None), (2.0, {"Left*": 3.0})]


@pytest.mark.parametrize("name", CLIPS)
def test_c_pipeline_gives_the_steps_composed_by_hand(name):
    m = _read(name)
    for alpha, joints in CASES:
        if joints and not any(fnmatch.fnmatchcase(n, "Left*") for n in m.joint_names):
            continue
        *ref, h = _reference(m, alpha, joints)
        *got, _p = _c_run(m, alpha, joints)
        dt, dq = _diff(got, ref, h)
        assert dt <= TOL and dq <= TOL, (name, alpha, dt, dq)
    if name.startswith("wild/") and "zup" in name:
        v = ffi.new("double *")
        check(lib.mlr_pipeline_get(_p, lib.MLR_PIPELINE_INFO_UP, v), "get")
        assert v[0] == 2 and m.up_axis == "z"


@pytest.mark.parametrize("name", CLIPS)
def test_stylize_and_denoise_are_the_c_pipeline(name):
    m = _read(name)
    h = body_height(m)
    for alpha, joints in CASES:
        if joints and not any(fnmatch.fnmatchcase(n, "Left*") for n in m.joint_names):
            continue
        py = mlayer.denoise(m) if alpha == 1.0 else mlayer.stylize(m, alpha, joints)
        *c, _ = _c_run(m, alpha, joints)
        dt, dq = _diff((py.root_pos, py.rot, py.trans), c, h)
        assert dt <= TOL and dq <= TOL, (name, alpha, dt, dq)


def test_trim_up_and_switches_as_the_python_options():
    """TRIM -1 is read_bvh(trim="auto"), UP and the guards' switches as stylize's keywords."""
    p = mocap_dir() / "cmu_01_01_playground_jumps.bvh"  # a T-pose lead-in of 1 frame
    if not p.is_file():
        pytest.skip(f"shared clip not found: {p}")
    full = mlayer.read_bvh(p)[:400]
    trimmed = mlayer.model.trimming.trim(full, "auto")
    assert trimmed.n_frames == full.n_frames - 1
    h = body_height(trimmed)
    py = mlayer.stylize(trimmed, 2.0)
    *c, pipe = _c_run(full, 2.0, trim=-1)
    assert max(_diff((py.root_pos, py.rot, py.trans), c, h)) <= TOL
    v = ffi.new("double *")
    check(lib.mlr_pipeline_get(pipe, lib.MLR_PIPELINE_INFO_TRIMMED, v), "get")
    assert v[0] == 1
    py = mlayer.stylize(trimmed, 2.0, up="y", floor=None, limits=True, keep_contacts=False,
                        root_alpha=0.5, robust=False, gamma=2.0)
    *c, _ = _c_run(trimmed, 2.0, up=1, floor=0, limits=2, keep_contacts=0, root_alpha=0.5,
                   robust=0, gamma=2.0)
    assert max(_diff((py.root_pos, py.rot, py.trans), c, h)) <= TOL
    py = mlayer.stylize(trimmed, 2.0, floor=h * 0.01, lam_c=1.0, sigma_c=1.0, base_cutoff=None)
    *c, _ = _c_run(trimmed, 2.0, floor=2, floor_height=h * 0.01, lam_c=1.0, sigma_c=1.0,
                   base_cutoff=0)
    assert max(_diff((py.root_pos, py.rot, py.trans), c, h)) <= TOL


@pytest.mark.parametrize("pattern", ["Left*", "*Foot", "?ips", "[LR]*", "[!L]*", "*Up*",
                                     "Right[A-H]*", "[]]x", "LeftFoot"])
def test_joint_patterns_are_fnmatch(pattern):
    """The C pipeline's joint patterns pick the joints fnmatch.fnmatchcase picks."""
    m = mlayer.data.load_sample()[:120]
    names = m.joint_names
    hits = [n for n in names if fnmatch.fnmatchcase(n, pattern)]
    if not hits:
        with pytest.raises(mlayer.InvalidArgumentError, match="matches no joint"):
            _c_run(m, 1.0, {pattern: 2.0}, guards=0)
        return
    py = mlayer.decompose(m, body_height=body_height(m)).synthesize(1.0, {pattern: 2.0})
    got = _c_run(m, 1.0, {pattern: 2.0}, guards=0)
    assert max(_diff((py.root_pos, py.rot, py.trans), got[:3], 1.0)) == 0.0
    assert not np.array_equal(got[1], _c_run(m, 1.0, guards=0)[1])


def test_one_synthesis_run_from_threads_gives_what_it_gives_alone():
    """Synthesis.run sets the alphas of its one C pipeline and synthesizes: a lock keeps the
    threads of a server (the viewer's) from mixing their alphas."""
    from concurrent.futures import ThreadPoolExecutor
    m = mlayer.data.load_sample()[:300]
    s = mlayer.Synthesis(m)
    alphas = [0.5, 1.0, 1.5, 2.0, 2.5, 3.0] * 3
    alone = {a: s.run(a)[0].rot for a in set(alphas)}
    with ThreadPoolExecutor(4) as pool:
        got = list(pool.map(lambda a: s.run(a)[0].rot, alphas))
    assert all(np.array_equal(g, alone[a]) for g, a in zip(got, alphas))
