"""Motion primitives and synthesis on the manifold (paper 2, sections 3-5).

:meth:`PrimitiveModel.fit` learns, from clips of one skeleton:

1. pose features (:func:`mlayer.pose_features`) and their 2-D manifold points: the best-matching
   unit of each frame on a SOM lattice (``manifold="som"``), or the first two principal
   components (``manifold="pca"``);
2. primitives: clusters of the manifold points (k-means, fuzzy c-means or a Gaussian mixture,
   ``cluster=``), k given or chosen (k="auto") by the elbow rule, the silhouette or the BIC of
   a Gaussian mixture (``criterion=``; :func:`mlayer.manifold.mixture.k_criteria` computes all
   three side by side);
3. their dynamics: a :class:`mlayer.Markov` model of consecutive frame labels, its jump model
   of the distinct primitives of order 1 .. 3 (``order=``, "auto": the best held-out
   log-likelihood, :func:`mlayer.manifold.markov.heldout_loglik`) with back-off (``min_count=``);
4. the generative GRBF mapping (:class:`mlayer.GRBF`) from manifold points to poses: body
   height, body velocity and turning rate in the heading frame, joint rotations (quaternions,
   the body joint's without its heading) and joint positions (the pose features).

The body joint is the joint that carries the body translation
(:func:`mlayer.layers.layers.body_translation_joint`): the root on most rigs; on rigs with a static
root above a moving pelvis (Bandai: ``joint_Root`` above ``Hips``) that pelvis, whose position
channels the generated motion then drives (the root keeps its training translation).

:meth:`PrimitiveModel.generate` turns a sequence of primitives (sampled from the Markov model or
followed by equation 5) or a list of key poses into a smooth path on the manifold (the LGS
spline through the primitives' centres, paced by their mean durations), resampled to N frames,
mapped to poses with the GRBF, smoothed with the LGS and returned as a :class:`mlayer.Motion`.

The guards (:meth:`PrimitiveModel.guard`, on by default) then make the generated motion fit for
a body, as :func:`mlayer.stylize` does: fit stores the contacts of every training frame, the
training clips' floor and what their joint limits are learned from; each generated frame gets
the contacts of the training frames nearest to its manifold point (a contact is cut where the
generated foot drifts more than a quarter of the body height from where it started: a pin there
would drag the foot), and the C guards (``mlr_guards.h``, :mod:`mlayer.manifold.generate_guards`)
pin each contact point at its mean position, keep the feet above the training floor and the joints
within the training clips' limits.
"""
from __future__ import annotations

import logging
import math
import os
import struct
import zlib
from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .. import _arrays, _attrs
from .._args import integer
from .._files import atomic_output
from .._native import lib
from .._progress import Bar, ProgressArg, resolve
from ..errors import InvalidArgumentError, MlayerIOError, MlayerWarning
from ..guards.cleanup import floor_height
from ..guards.contacts import contact_positions, detect_contacts
from ..guards.limits import joint_limits
from ..guards.metrics import body_height
from ..layers.layers import body_translation, body_translation_joint
from ..layers.smoothing import lgs
from ..model import quat
from ..model.motion import Motion, Skeleton, _frame_time_arg
from .clustering import kmeans
from .features import heading, pose_features
from .generate_guards import contacts_along, guard_motion, split_drifting
from .manifold import GRBF, PCA
from .markov import MAX_ORDER, Markov, Rng, best_order, contexts_from_arrays, heldout_loglik
from .mixture import CRITERIA, GaussianMixture, KCriteria, fuzzy_cmeans, k_criteria
from .som import SOM

if TYPE_CHECKING:
    from ..guards.limits import JointLimits
    from ..pipeline.pipeline import GuardReport

__all__ = ["PrimitiveModel", "heading_quat", "split_heading", "default_lattices", "same_units",
           "skeleton_difference", "join_skeletons", "rename_joints", "CMU_NAMES"]

_FORMAT = 2  # 2: jump contexts of order 1 .. 3, the k criteria, clip names; 1 loads as order 1
_FORMATS = (1, 2)
#: the format version of :meth:`PrimitiveModel.runtime_bytes` (``MLR_GEN_FORMAT_VERSION``)
RUNTIME_FORMAT = 1


def _fnv1a(data: bytes) -> int:
    """FNV-1a, 64 bits (the skeleton hash of a runtime model file)."""
    h = 0xcbf29ce484222325
    for byte in data:
        h = ((h ^ byte) * 0x100000001b3) & 0xFFFFFFFFFFFFFFFF
    return h
# SOM manifold points are lattice positions (the BMU's, rounded to the unit): the GMM of the BIC
# criterion adds the variance of that rounding, 1/12 per axis, to its covariances
_SOM_REG_COVAR = 1.0 / 12.0
CLUSTERS = ("kmeans", "fcm", "gmm")
#: What the primitives cluster: the manifold's 2-D points (the paper's) or the pose features.
CLUSTER_ON = ("manifold", "features")
# generated contacts: a pin holds while the generated foot drifts at most this many body heights
# from where the contact started; a new contact starts after a gap of _PIN_GAP seconds
_PIN_DRIFT = 0.25
_PIN_GAP = 0.1


def _yaw(rot_root: ArrayLike) -> NDArray[np.float64]:
    return heading(rot_root)


def heading_quat(yaw: ArrayLike) -> NDArray[np.float64]:
    """Unit quaternions of rotations by yaw about +Y.

    Parameters
    ----------
    yaw : array_like, shape (n,)
        Radians.

    Returns
    -------
    numpy.ndarray, shape (n, 4)
        Scalar-first quaternions.
    """
    yaw = np.asarray(yaw, dtype=np.float64)
    q = np.zeros(yaw.shape + (4,))
    q[..., 0] = np.cos(yaw / 2)
    q[..., 2] = np.sin(yaw / 2)
    return q


def split_heading(rot_root: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Split root rotations into yaw and the rotation without heading.

    ``rot_root = heading_quat(yaw) * rest``.

    Parameters
    ----------
    rot_root : array_like, shape (n, 4)
        Root rotations.

    Returns
    -------
    yaw : numpy.ndarray, shape (n,)
        Radians about +Y.
    rest : numpy.ndarray, shape (n, 4)
        The rotations without heading.
    """
    yaw = _yaw(rot_root)
    return yaw, quat.mul(quat.conj(heading_quat(yaw)), rot_root)


def _hemisphere(q: NDArray[np.float64]) -> NDArray[np.float64]:
    """Flip the quaternions (n, J, 4) of each joint to the hemisphere of that joint's principal
    axis (the eigenvector of sum q q^T), so that linear regression on them is meaningful."""
    out = q.copy()
    for j in range(q.shape[1]):
        M = q[:, j].T @ q[:, j]
        ref = np.linalg.eigh(M)[1][:, -1]
        out[:, j] *= np.where(q[:, j] @ ref < 0, -1.0, 1.0)[:, None]
    return out


def _non_negative(v: Any, name: str) -> float:
    """A finite number >= 0, else InvalidArgumentError naming it (NaN compares false with
    everything, so ``smooth=nan`` used to pass ``smooth > 0`` checks silently)."""
    f = _arrays.finite(v, name)
    if f < 0:
        raise InvalidArgumentError(f"{name} must be >= 0, got {v!r}")
    return f


# The defaults of fit scale with the training frames from these (the paper's sizes) down.
MIN_FRAMES = 16
UNIT_RATIO = 2.0


def default_lattices(n_frames: int) -> tuple[tuple[int, int], tuple[int, int]]:
    """The default SOM lattice and GRBF centre lattice of :meth:`PrimitiveModel.fit`.

    Parameters
    ----------
    n_frames : int
        Training frames n.

    Returns
    -------
    som : tuple of int
        (s, s) with s = min(30, isqrt(n)).
    lattice : tuple of int
        (g, g) with g = min(15, isqrt(n // 4)).

    Raises
    ------
    mlayer.InvalidArgumentError
        Below :data:`MIN_FRAMES` frames.
    """
    n = int(n_frames)
    if n < MIN_FRAMES:
        raise InvalidArgumentError(
            f"primitives: {n} training frames are too few for the default lattices (at least "
            f"{MIN_FRAMES}; give som= and lattice=, --som and --lattice, to try smaller ones)")
    s, g = min(30, math.isqrt(n)), min(15, math.isqrt(n // 4))
    return (s, s), (g, g)


def same_units(clips: Sequence[Motion]) -> list[Motion]:
    """Clips in other units than the first scaled to its body height.

    A clip is in other units when its body height differs from the first clip's by a ratio of
    :data:`UNIT_RATIO` or more (see :meth:`PrimitiveModel.fit`); each scaling is warned about
    (:class:`mlayer.MlayerWarning`).

    Parameters
    ----------
    clips : sequence of Motion
        At least one clip.

    Returns
    -------
    list of Motion
        The clips, scaled where needed.
    """
    import warnings
    h0 = body_height(clips[0])
    out = [clips[0]]
    for i, m in enumerate(clips[1:], 1):
        h = body_height(m)
        if not (h0 > 0 and h > 0) or max(h / h0, h0 / h) < UNIT_RATIO:
            out.append(m)
            continue
        f = h0 / h
        sk = m.skeleton
        scaled = Skeleton(sk.joint_names, sk.parents, sk.offsets * f, sk.channels,
                          sk.end_site_parents, sk.end_site_offsets * f)
        out.append(Motion(scaled, m.frame_time, m.root_pos * f, m.rot, m.trans * f)
                   ._same_up(m))
        warnings.warn(MlayerWarning(
            f"primitives: clip {i} is in other units than clip 0 (body height {h:.4g} against "
            f"{h0:.4g}): scaled by {f:.4g} to clip 0's size"), stacklevel=3)
    return out


#: the candidate ks of k="auto" when none are given
DEFAULT_KS = range(2, 21)


def _span(ks: Sequence[int]) -> str:
    """Sorted candidate ks in words: "2..20" for a run, else the list."""
    ks = list(ks)
    if len(ks) > 1 and ks == list(range(ks[0], ks[-1] + 1)):
        return f"{ks[0]}..{ks[-1]}"
    return ", ".join(map(str, ks))


#: CMU's two names of the joints of its 31-joint skeleton: the conversions of subject 131 and
#: others (keys) and those of subjects 01-09 (values), the same tree. ``rename=CMU_NAMES``
#: (``--rename cmu``) joins clips of the two.
CMU_NAMES = {
    "LeftHip": "LeftUpLeg", "LeftKnee": "LeftLeg", "LeftAnkle": "LeftFoot",
    "LeftToe": "LeftToeBase", "RightHip": "RightUpLeg", "RightKnee": "RightLeg",
    "RightAnkle": "RightFoot", "RightToe": "RightToeBase", "lowerback": "LowerBack",
    "Chest": "Spine", "Chest2": "Spine1", "lowerneck": "Neck", "Neck": "Neck1",
    "LeftCollar": "LeftShoulder", "LeftShoulder": "LeftArm", "LeftElbow": "LeftForeArm",
    "LeftWrist": "LeftHand", "lhand": "LeftFingerBase", "RightCollar": "RightShoulder",
    "RightShoulder": "RightArm", "RightElbow": "RightForeArm", "RightWrist": "RightHand",
    "rhand": "RightFingerBase"}


def skeleton_difference(a: Skeleton, b: Skeleton, b_name: str = "the first clip"
                        ) -> str | None:
    """Where skeleton ``a`` first differs from ``b`` in joint names or tree, in words, or None.

    Joints are compared in their (depth-first) order: the first joint whose name or parent
    differs is named; then a joint count that differs.

    Parameters
    ----------
    a, b : Skeleton
        The skeletons.
    b_name : str, optional
        What ``b`` is called in the words.

    Returns
    -------
    str or None
        For example ``"joint 2 is 'LeftHip' where the first clip has 'LeftUpLeg'"``; None
        when the names and the parents are the same.
    """
    return _difference(a.joint_names, a.parents, b.joint_names, b.parents, b_name)


def _difference(na: list[str], pa: Any, nb: list[str], pb: Any, b_name: str) -> str | None:
    for j in range(min(len(na), len(nb))):
        if na[j] != nb[j]:
            return f"joint {j} is {na[j]!r} where {b_name} has {nb[j]!r}"
        if pa[j] != pb[j]:
            return (f"joint {j} {na[j]!r} has the parent {na[pa[j]]!r} where {b_name} has "
                    f"{nb[pb[j]]!r}")
    if len(na) != len(nb):
        extra = (f" (from {na[len(nb)]!r})" if len(na) > len(nb) else
                 f" (missing {nb[len(na)]!r})")
        return f"{len(na)} joints where {b_name} has {len(nb)}{extra}"
    return None


def rename_joints(motion: Motion, mapping: dict[str, str]) -> Motion:
    """The motion with its joints renamed (the frames, tree and channels as they are).

    Parameters
    ----------
    motion : Motion
        The clip.
    mapping : dict of str to str
        Old name to new name, all at once (``{"Neck": "Neck1", "lowerneck": "Neck"}`` swaps
        nothing twice); names not in it are kept, keys the clip does not have are ignored.

    Returns
    -------
    Motion
        A new motion; the same up axis and units.

    Raises
    ------
    mlayer.InvalidArgumentError
        When two joints would have one name.
    """
    sk = motion.skeleton
    names = [str(mapping.get(n, n)) for n in sk.joint_names]
    if len(set(names)) != len(names):
        dup = next(n for n in names if names.count(n) > 1)
        raise InvalidArgumentError(f"option rename: two joints would be named {dup!r}")
    renamed = Skeleton(names, sk.parents, sk.offsets, sk.channels, sk.end_site_parents,
                       sk.end_site_offsets)
    return Motion(renamed, motion.frame_time, motion.root_pos, motion.rot, motion.trans) \
        ._same_up(motion)


def _rename_arg(rename: Any) -> dict[str, str] | None:
    if rename is None:
        return None
    if not isinstance(rename, dict) or not all(isinstance(k, str) and isinstance(v, str)
                                               for k, v in rename.items()):
        raise InvalidArgumentError(f"option rename must map joint names to joint names (a dict "
                                   f"of str), got {type(rename).__name__}")
    return dict(rename)


def join_skeletons(clips: Sequence[Motion], *, rename: dict[str, str] | None = None,
                   names: Sequence[str] | None = None, reference: Skeleton | None = None,
                   reference_name: str | None = None) -> list[Motion]:
    """Clips checked to have one skeleton, joint names and tree, before any work on them.

    Every clip is compared with the reference (default the first clip): a clip that differs
    is renamed by ``rename`` (or by its inverse, whichever gives the reference's names; so one
    mapping between two naming schemes joins clips of either to the first), and a clip that
    still differs is an error naming the clip and its first differing joint.

    Parameters
    ----------
    clips : sequence of Motion
        The clips.
    rename : dict of str to str, optional
        Old joint name to new (:func:`rename_joints`), such as :data:`CMU_NAMES`.
    names : sequence of str, optional
        The clips' names, for the message (default "clip I").
    reference : Skeleton, optional
        The skeleton to match (a model's); default the first clip's.
    reference_name : str, optional
        What the reference is called in the message.

    Returns
    -------
    list of Motion
        The clips, renamed where needed.

    Raises
    ------
    mlayer.InvalidArgumentError
        In one line: ``clip 1 (b.bvh): joint 2 is 'LeftHip' where clip 0 (a.bvh) has
        'LeftUpLeg'; ...``.
    """
    rename = _rename_arg(rename)
    clips = list(clips)

    def label(i: int) -> str:
        return f"clip {i}" + (f" ({names[i]})" if names is not None and names[i] != str(i)
                              else "")
    first = 0
    if reference is None:
        reference, first = clips[0].skeleton, 1
        reference_name = reference_name or label(0)
    ref_name = reference_name or "the model"
    mappings: list[dict[str, str]] = []
    if rename:
        mappings.append(rename)
        inverse = {v: k for k, v in rename.items()}
        if len(inverse) == len(rename):
            mappings.append(inverse)
    out = clips[:first]
    for i in range(first, len(clips)):
        m = clips[i]
        diff = skeleton_difference(m.skeleton, reference, ref_name)
        if diff is None:
            out.append(m)
            continue
        for mp in mappings:
            names_i = [mp.get(n, n) for n in m.skeleton.joint_names]
            if len(set(names_i)) == len(names_i) and names_i == reference.joint_names and \
                    np.array_equal(m.skeleton.parents, reference.parents):
                out.append(rename_joints(m, mp))
                break
        else:
            if rename:  # where the renamed clip still differs
                renamed = [rename.get(n, n) for n in m.skeleton.joint_names]
                diff = _difference(renamed, m.skeleton.parents, reference.joint_names,
                                   reference.parents, ref_name) or diff
            same_tree = np.array_equal(m.skeleton.parents, reference.parents)
            hint = ("" if not same_tree else "; option rename did not join them" if rename else
                    "; join two naming schemes with option rename")
            raise InvalidArgumentError(f"{label(i)}: another skeleton: {diff}{hint}")
    return out


def _check_plan(n: int, k: int | str, ks: Iterable[int] | None, criterion: str, cluster: str,
                order: int | str, min_count: int, manifold: str, som: Any, lattice: Any,
                names: Sequence[str] | None, n_clips: int,
                cluster_on: str = "manifold") -> dict[str, Any]:
    """The arguments of :meth:`PrimitiveModel.fit` checked against the n training frames before
    any training: k and the candidate ks given at most the frames and the SOM's units (the
    distinct manifold points a SOM can give), the default candidates cut to that bound with a
    note in the log that says so, the GRBF lattice at most n centres."""
    if criterion not in CRITERIA:
        raise InvalidArgumentError(f"option criterion must be one of {', '.join(CRITERIA)}, "
                                   f"got {criterion!r}")
    if cluster not in CLUSTERS:
        raise InvalidArgumentError(f"option cluster must be one of {', '.join(CLUSTERS)}, got "
                                   f"{cluster!r}")
    if cluster_on not in CLUSTER_ON:
        raise InvalidArgumentError(f"option cluster_on must be one of {', '.join(CLUSTER_ON)}, "
                                   f"got {cluster_on!r}")
    if order != "auto":
        order = integer(order, "option order", 1, MAX_ORDER)
    min_count = integer(min_count, "option min_count", 1)
    limit, where = n, f"the number of training frames ({n})"
    if manifold == "som" and cluster_on == "manifold":
        units = int(som[0]) * int(som[1])
        if units < limit:
            limit, where = units, (f"the SOM's {int(som[0])}x{int(som[1])} = {units} units (a "
                                   f"SOM gives at most that many distinct manifold points)")
    if k != "auto":
        k = integer(k, "option k", 1)
        if k > limit:
            raise InvalidArgumentError(f"option k = {k} exceeds {where}")
    default = ks is None
    given: Iterable[int] = (DEFAULT_KS if k == "auto" else ()) if ks is None else ks
    ks = sorted({integer(q, "option ks", 1) for q in given})
    cut = [q for q in ks if q <= limit]
    if ks and not cut and (k == "auto" or not default):
        raise InvalidArgumentError(f"option ks: every candidate k exceeds {where}")
    if not default and len(cut) < len(ks):
        raise InvalidArgumentError(
            f"option ks = {_span(ks)} exceeds {where}: give candidates up to {limit} (such "
            f"as {_span(cut)})")
    if len(cut) < len(ks):
        _log.info(f"primitives: candidate ks {_span(ks)} cut to {_span(cut)}: at most {where}")
    if lattice is not None:
        cells = int(lattice[0]) * int(lattice[1])
        if cells > n:
            raise InvalidArgumentError(
                f"option lattice {int(lattice[0])}x{int(lattice[1])} = {cells} GRBF centres "
                f"exceeds the number of training frames ({n}); give a smaller lattice")
    if names is None:
        names = [str(i) for i in range(n_clips)]
    else:
        names = [str(v) for v in names]
        if len(names) != n_clips or len(set(names)) != n_clips:
            raise InvalidArgumentError(f"names: need {n_clips} distinct clip names, got "
                                       f"{names!r}")
    return dict(k=k, ks=cut, criterion=criterion, cluster=cluster, order=order,
                min_count=min_count, names=names, cluster_on=cluster_on)


#: the steps of PrimitiveModel.fit are logged here (INFO); the command line shows them
_log = logging.getLogger("mlayer.manifold.primitives")

#: the steps PrimitiveModel.fit's progress bar counts: features, manifold, primitives, GRBF,
#: guards
_FIT_STEPS = 5


class _Steps:
    """Where the steps of a fit go: the ``mlayer.manifold.primitives`` logger (INFO), fit's on_step
    callable, and its progress bar (advanced after each of the :data:`_FIT_STEPS` steps)."""

    def __init__(self, bar: Bar, on_step: Callable[[str], object] | None = None) -> None:
        self.bar, self.on_step = bar, on_step

    def say(self, msg: str, advance: bool = False) -> None:
        _log.info(msg)
        if self.on_step is not None:
            self.on_step(msg)
        if advance:
            self.bar.update(1)


def _say(steps: _Steps, msg: str, advance: bool = False) -> None:
    """One step of a fit (see :class:`_Steps`)."""
    steps.say(msg, advance)


def _clip_names(model: Any, v: Any, name: str) -> list[str]:
    """PrimitiveModel.clip_names: one distinct str per training clip."""
    if isinstance(v, (str, bytes)) or not isinstance(v, (list, tuple)) \
            or not all(isinstance(x, str) for x in v):
        raise InvalidArgumentError(f"{name} must be a list of str, got {v!r}"[:200])
    n = len(model.__dict__.get("clip_starts", v))
    if len(v) != n or len(set(v)) != len(v):
        raise InvalidArgumentError(f"{name} must be {n} distinct names (one per training "
                                   f"clip), got {list(v)!r}"[:200])
    return list(v)


def _markov(model: Any, v: Any, name: str) -> Markov:
    """PrimitiveModel.markov: a Markov model of as many states as there are primitives."""
    if not isinstance(v, Markov):
        raise InvalidArgumentError(f"{name} must be a mlayer.Markov, got {type(v).__name__}")
    centers = model.__dict__.get("centers")
    if centers is not None and v.n_states != centers.shape[0]:
        raise InvalidArgumentError(f"{name} must have {centers.shape[0]} states (one per "
                                   f"primitive), got {v.n_states}")
    return v


class PrimitiveModel(_attrs.ReadOnlyAttributes):
    """A learned motion manifold with primitives; build it with :meth:`fit` or :meth:`load`.

    Attributes: ``skeleton``, ``frame_time``, ``body_joint`` (the joint whose translation and
    heading the mapping drives; 0 for the root), ``manifold`` ("som" or "pca"), ``points``
    (n, 2) manifold point of every training frame, ``clip_starts`` (first frame of each clip),
    ``labels`` (n,), ``centers`` (k, 2) primitive centres on the manifold, ``markov``,
    ``grbf``, ``bounds`` (the manifold box the GRBF lattice spans), ``elbow_ks`` and
    ``elbow_inertia`` (the curve when k was chosen automatically), ``k_source`` (where k came
    from: ``"given"`` for an integer k, else the criterion that picked it, ``"elbow"``,
    ``"silhouette"`` or ``"bic"``; None in model files written before it was stored),
    ``som_codebook`` (rows, cols, dim) or ``pca_mean``/``pca_components``.

    Four can be assigned, checked where they are (InvalidArgumentError naming the attribute
    otherwise): ``frame_time`` (seconds, as :attr:`mlayer.Motion.frame_time`),
    ``floor_height`` (finite, or NaN for no floor), ``clip_names`` (one distinct str per
    training clip) and ``markov`` (a :class:`mlayer.Markov` of one state per primitive, e.g.
    ``model.markov.perturbed(0.1)``). The others are read-only (AttributeError): they were
    learned together and their shapes depend on each other.
    """
    clip_names: list[str]
    skeleton: Skeleton
    frame_time: float
    clip_starts: NDArray[np.int64]
    som_codebook: NDArray[np.float64]
    points: NDArray[np.float64]
    pca_mean: NDArray[np.float64]
    pca_components: NDArray[np.float64]
    grbf: GRBF
    fit_error: float
    criterion: str
    cluster: str
    cluster_on: str
    k_source: str | None
    centers: NDArray[np.float64]
    labels: NDArray[np.intp]
    order_loglik: dict[int, tuple[float, int]]
    markov: Markov
    train_rot: NDArray[np.float64]
    train_trans: NDArray[np.float64]
    floor_height: float
    body_joint: int
    rest_root_pos: NDArray[np.float64]
    rest_trans: NDArray[np.float64]

    _readonly = ("skeleton", "body_joint", "manifold", "points", "clip_starts", "labels",
                 "centers", "grbf", "bounds", "elbow_ks", "elbow_inertia", "som_codebook",
                 "pca_mean", "pca_components", "criteria", "criterion", "cluster", "cluster_on",
                 "k_source",
                 "order_loglik", "contacts", "contact_names", "train_rot", "train_trans",
                 "rest_root_pos", "rest_trans", "fit_error")
    _checked = {"frame_time": lambda m, v, name: _frame_time_arg(v, name),
                "floor_height": _attrs.number(nan=True), "clip_names": _clip_names,
                "markov": _markov}

    criteria: KCriteria | None
    contacts: NDArray[np.bool_] | None
    elbow_ks: NDArray[Any]
    elbow_inertia: NDArray[Any]
    bounds: Any

    # -- learning ------------------------------------------------------------------------------

    @classmethod
    def fit(cls, clips: Motion | Sequence[Motion], *, k: int | str = "auto",
            ks: Iterable[int] | None = None, criterion: str = "elbow", cluster: str = "kmeans",
            cluster_on: str = "manifold",
            order: int | str = 1, min_count: int = 1, manifold: str = "som",
            som: tuple[int, int] | None = None, epochs: int = 20,
            lattice: tuple[int, int] | None = None, kernel: str = "thin_plate",
            smoothing: float = 1e-6, seed: int = 0, progress: ProgressArg = None,
            names: Sequence[str] | None = None,
            on_step: Callable[[str], object] | None = None,
            rename: dict[str, str] | None = None) -> PrimitiveModel:
        """Learn a model from one motion or a list of motions of one skeleton.

        k, ks and the lattices are checked against the number of frames before any training.
        The steps are logged (INFO) to the ``mlayer.manifold.primitives`` logger.

        Defaults that scale with n, the number of training frames (:func:`default_lattices`):
        ``som`` s x s units with s = min(30, isqrt(n)) (about one frame per unit; the paper's
        30 x 30 from 900 frames on), ``lattice`` g x g GRBF centres with
        g = min(15, isqrt(n // 4)) (at least 4 frames per centre; the paper's 15 x 15 from 900
        frames on), and never more centres per side than the SOM has units. They need
        :data:`MIN_FRAMES` (16) frames; with fewer, give both ``som`` and ``lattice``.

        Units: a clip whose body height (:func:`mlayer.guards.metrics.body_height`, along its up
        axis) differs from the first clip's by a factor of :data:`UNIT_RATIO` (2) or more is
        in other units (cm and m, CMU's 5.6 cm units and cm, inches and cm; people differ by
        less): it is scaled (its OFFSETs, root and position channels) to the first clip's
        height, with an :class:`mlayer.MlayerWarning` that says by how much. The model is in
        the first clip's units.

        Parameters
        ----------
        clips : Motion or sequence of Motion
            The training clips (each at least 2 frames).
        k : int or "auto", optional
            Number of primitives, or ``"auto"``: the pick of ``criterion`` over ``ks``.
        ks : iterable of int, optional
            The candidate ks of the criteria; with an integer k they are computed and stored
            all the same, in ``criteria``. Every candidate given must be at most the number
            of training frames and, with a SOM, its units (rows x cols: a SOM gives no more
            distinct manifold points), else InvalidArgumentError before any training. Default
            (None): 2 .. 20 when k is "auto", none for an integer k; cut to that bound when it
            is smaller, with a note in the log (INFO, the ``mlayer.manifold.primitives`` logger;
            the command line shows it) that says so.
        criterion : {"elbow", "silhouette", "bic"}, optional
            How ``"auto"`` picks k.
        cluster : {"kmeans", "fcm", "gmm"}, optional
            What labels the frames and places the primitives' centres: k-means, fuzzy c-means
            (each frame in its cluster of largest membership) or a Gaussian mixture (the most
            responsible component), both started from the k-means centres; clusters that get
            no frame are dropped.
        cluster_on : {"manifold", "features"}, optional
            What is clustered (and what the k criteria measure): the manifold's 2-D points
            (paper 2, section 4.1: "the low dimensional representation"; the default) or the
            pose features (:func:`mlayer.manifold.features.pose_features`, 3 x joints dimensions).
            With features, each primitive's centre on the map is the mean of its frames' points.
            What each gives on walks and dances: docs/primitives.md.
        order : int or "auto", optional
            1 .. 3, or ``"auto"`` (the order of best held-out log-likelihood).
        min_count : int, optional
            The back-off rule of the jump model (:class:`mlayer.Markov`).
        manifold : {"som", "pca"}, optional
            A rows x cols SOM (batch training for ``epochs``) or PCA.
        som : tuple of int, optional
            The SOM's (rows, cols).
        epochs : int, optional
            SOM training passes.
        lattice : tuple of int, optional
            The GRBF's centre lattice.
        kernel : str, optional
            The GRBF's kernel.
        smoothing : float, optional
            The GRBF's ridge (a small relative ridge keeps the weights of lattice centres with
            no training frame nearby determined).
        seed : int, optional
            Seed of every random step.
        progress : None, bool, stream or callable, optional
            A bar over the steps (None: on when stderr is a terminal and tqdm is installed;
            True, False, a stream, or a callable ``f(done, total)``).
        names : sequence of str, optional
            The clips' names (default their index), for :meth:`generate`'s keys.
        on_step : callable, optional
            Also given each step's line as it is logged (the viewer shows them).
        rename : dict of str to str, optional
            Joint names of another naming scheme mapped to the first clip's
            (:func:`join_skeletons`; :data:`CMU_NAMES` for CMU's two). Every clip must have
            the first clip's joint names and tree, after this renaming; that is checked before
            any work, and the first differing joint is named.

        Returns
        -------
        PrimitiveModel
            The model.

        Raises
        ------
        mlayer.InvalidArgumentError
            For no clips, clips too short, clips of other skeletons (names or tree), or a
            plan that does not fit the frames.
        """
        clips = list(clips) if isinstance(clips, (list, tuple)) else [cast(Motion, clips)]
        if not clips:
            raise InvalidArgumentError("PrimitiveModel.fit: no clips")
        for m in clips:
            if not isinstance(m, Motion):
                raise InvalidArgumentError(f"PrimitiveModel.fit: expected Motion objects, got "
                                           f"{type(m).__name__}")
            if m.n_frames < 2:
                raise InvalidArgumentError("PrimitiveModel.fit: every clip needs >= 2 frames")
        if manifold not in ("som", "pca"):
            raise InvalidArgumentError(f"manifold must be 'som' or 'pca', got {manifold!r}")
        clips = join_skeletons(clips, rename=rename,
                               names=[str(v) for v in names] if names is not None and
                               len(names) == len(clips) else None)
        if lattice is None or (manifold == "som" and som is None):
            som_d, lattice_d = default_lattices(sum(m.n_frames for m in clips))
            som = som_d if som is None else som
            if lattice is None:
                lattice = lattice_d if manifold != "som" else cast(tuple[int, int], tuple(
                    min(g, int(s)) for g, s in zip(lattice_d, som)))
        n_frames = sum(m.n_frames for m in clips)
        plan = _check_plan(n_frames, k, ks, criterion, cluster, order, min_count, manifold,
                           som, lattice, names, len(clips), cluster_on)
        make_bar = resolve(progress, "PrimitiveModel.fit")  # before any work
        clips = same_units(clips)
        with make_bar(_FIT_STEPS, "primitives", "step") as bar:
            return cls()._fit(clips, plan, _Steps(bar, on_step), manifold=manifold, som=som,
                              epochs=epochs, lattice=lattice, kernel=kernel,
                              smoothing=smoothing, seed=seed)

    @_attrs.builds
    def _fit(self, clips: list[Motion], plan: dict[str, Any], progress: _Steps, *,
             manifold: str, som: Any, epochs: int, lattice: Any, kernel: str,
             smoothing: float, seed: int) -> PrimitiveModel:
        """The steps of :meth:`fit` on checked arguments (`plan`: _check_plan's; clips in one
        unit; `progress`: where the steps go)."""
        self.clip_names = plan["names"]
        self.skeleton = clips[0].skeleton
        self.frame_time = float(np.median([m.frame_time for m in clips]))
        self._set_body(body_translation_joint(clips), clips)
        _say(progress, f"features: {len(clips)} clip(s), "
                       f"{sum(m.n_frames for m in clips)} frames")
        X = pose_features(clips)
        progress.bar.update(1)
        self.clip_starts = np.cumsum([0] + [m.n_frames for m in clips[:-1]]).astype(np.int64)
        self.manifold = manifold
        if manifold == "som":
            rows, cols = (int(v) for v in som)
            _say(progress, f"SOM {rows}x{cols}: {epochs} batch epochs on {X.shape[0]} x "
                           f"{X.shape[1]}")
            s = SOM(rows, cols, X.shape[1], seed=seed)
            s.train(X, epochs, mode="batch")
            self.som_codebook = s.codebook
            self.points = s.bmu(X).astype(np.float64)
            self.bounds = ((0.0, rows - 1.0), (0.0, cols - 1.0))
            _say(progress, f"SOM: quantization error {s.quantization_error(X):.4g}, "
                           f"topographic error {s.topographic_error(X):.3f}, "
                           f"{len(np.unique(s.bmu_index(X)))} units used")
        else:
            p = PCA(2).fit(X)
            self.pca_mean, self.pca_components = p.mean_, p.components_
            self.points = p.transform(X)
            self.bounds = tuple((float(self.points[:, j].min()), float(self.points[:, j].max()))
                                for j in range(2))
        progress.bar.update(1)
        self._set_primitives(plan, seed, progress, X)
        Y = self._targets(clips, X)
        _say(progress, f"GRBF: {kernel}, {lattice[0]}x{lattice[1]} centres, "
                       f"{X.shape[0]} frames -> {Y.shape[1]} outputs")
        self.grbf = GRBF(kernel, lattice, bounds=self.bounds,
                         smoothing=smoothing).fit(self.points, Y)
        fit = self.grbf.predict(self.points)
        J = self.skeleton.n_joints
        err = np.sqrt(((fit[:, -3 * J:] - X) ** 2).reshape(-1, J, 3).sum(-1)).mean()
        self.fit_error = float(err)
        _say(progress, f"GRBF: mean joint position error on the training frames {err:.4g}",
             True)
        self._set_guards(clips)
        _say(progress, f"guards: {len(self.contact_names)} contact points, floor "
                       f"{self.floor_height:.4g}", True)
        return self

    def _set_primitives(self, plan: dict[str, Any], seed: int, progress: _Steps,
                        features: NDArray[np.float64] | None = None) -> None:
        """Primitives (labels, centres), the k criteria and the Markov model of the labels."""
        ks, k = plan["ks"], plan["k"]
        self.cluster_on = plan.get("cluster_on", "manifold")
        on_features = self.cluster_on == "features" and features is not None
        Z = np.ascontiguousarray(features, np.float64) if on_features else self.points
        reg = _SOM_REG_COVAR if self.manifold == "som" and not on_features else 1e-6 * float(
            max(Z.var(axis=0).max(), 1e-300))
        self.criterion, self.cluster = plan["criterion"], plan["cluster"]
        self.k_source = "given" if k != "auto" else self.criterion
        km = None
        if ks:
            _say(progress, f"k criteria (elbow, silhouette, GMM BIC): k = {ks[0]} .. {ks[-1]}")
            c = k_criteria(Z, ks, seed=seed, n_init=3, reg_covar=reg)
            self.criteria = c
            self.elbow_ks, self.elbow_inertia = np.asarray(c.ks), np.asarray(c.inertia)
            if k == "auto":
                k = c.picks[self.criterion]
            if k in list(c.ks):
                km = c.results[list(c.ks).index(k)]
        else:
            self.criteria = None
            self.elbow_ks = self.elbow_inertia = np.zeros(0)
        if km is None:
            km = kmeans(Z, k, seed=seed, n_init=3)
        centers, labels = np.asarray(km.centers, np.float64), np.asarray(km.labels, np.int64)
        if self.cluster == "fcm":
            f = fuzzy_cmeans(Z, k, init=centers, seed=seed)
            centers, labels = f.centers, np.asarray(f.labels, np.int64)
        elif self.cluster == "gmm":
            g = GaussianMixture(k, init=centers, reg_covar=reg, seed=seed).fit(Z)
            centers, labels = g.means_, np.asarray(g.predict(Z), np.int64)
        used = np.unique(labels)  # a cluster that got no frame is no primitive
        if on_features:  # each primitive's centre on the map: the mean of its frames' points
            centers = np.stack([self.points[labels == c].mean(axis=0) if (labels == c).any()
                                else np.zeros(self.points.shape[1])
                                for c in range(int(labels.max()) + 1)])
        self.centers = np.ascontiguousarray(centers[used], dtype=np.float64)
        self.labels = np.searchsorted(used, labels).astype(np.int64)
        k = self.centers.shape[0]
        _say(progress, f"primitives: k = {k} ({self.cluster}"
                       + (", on the pose features" if on_features else "")
                       + (f", {self.criterion}" if plan["k"] == "auto" else "") + ")", True)
        seqs = self.clip_labels()
        self.order_loglik = heldout_loglik(seqs, k, (1, 2, 3), min_count=plan["min_count"])
        order = best_order(self.order_loglik) if plan["order"] == "auto" else plan["order"]
        self.markov = Markov.fit(seqs, n_states=k, order=order, min_count=plan["min_count"])
        _say(progress, f"Markov: order {order}, min_count {plan['min_count']}")

    def clip_labels(self) -> list[NDArray[np.int64]]:
        """The primitive labels of each training clip.

        Returns
        -------
        list of numpy.ndarray
            One label array per clip.
        """
        ends = list(self.clip_starts[1:]) + [self.labels.shape[0]]
        return [self.labels[a:b] for a, b in zip(self.clip_starts, ends)]

    def clip_frames(self, clip: int | str) -> tuple[int, int]:
        """The frames of a training clip.

        Parameters
        ----------
        clip : int or str
            Its index or name (``clip_names``).

        Returns
        -------
        tuple of int
            (first training frame, number of frames).

        Raises
        ------
        mlayer.InvalidArgumentError
            Naming the keys, for an unknown clip.
        """
        n = len(self.clip_starts)
        names = list(getattr(self, "clip_names", []) or [str(i) for i in range(n)])
        if isinstance(clip, (int, np.integer)) and not isinstance(clip, (bool, np.bool_)):
            i = int(clip)
        elif isinstance(clip, str) and clip in names:
            i = names.index(clip)
        elif isinstance(clip, str) and clip.isdigit():
            i = int(clip)
        else:
            raise InvalidArgumentError(f"option keys: no training clip {clip!r} (the model's "
                                       f"clips: {', '.join(names)}, or their index 0 .. "
                                       f"{n - 1})")
        if not 0 <= i < n:
            raise InvalidArgumentError(f"option keys: clip index {i} out of range (the model "
                                       f"has {n} clips, 0 .. {n - 1})")
        end = int(self.clip_starts[i + 1]) if i + 1 < n else self.points.shape[0]
        return int(self.clip_starts[i]), end - int(self.clip_starts[i])

    def _set_guards(self, clips: list[Motion]) -> None:
        """What the guards of generated motion need from the training clips: the contacts of
        every training frame (:func:`mlayer.detect_contacts`, the points of the first clip),
        the floor (:func:`mlayer.guards.cleanup.floor_height` of those contacts over all clips) and
        the rotations and translations the joint limits are learned from."""
        names = None
        parts = []
        for m in clips:
            if m.n_frames >= 3:
                names, _ = detect_contacts(m, names) if names is not None \
                    else detect_contacts(m)
                break
        names = list(names) if names is not None else []
        for m in clips:
            if names and m.n_frames >= 3:
                parts.append(detect_contacts(m, names)[1])
            else:
                parts.append(np.zeros((m.n_frames, len(names)), dtype=bool))
        self.contact_names = names
        self.contacts = np.concatenate(parts).astype(bool)
        frames = [m._frames() for m in clips]
        self.train_rot = np.concatenate([f[1] for f in frames])
        self.train_trans = np.concatenate([f[2] for f in frames])
        self.floor_height = float("nan")
        if names and self.contacts.any():
            whole = Motion(self.skeleton, self.frame_time,
                           np.concatenate([f[0] for f in frames]), self.train_rot,
                           self.train_trans)
            self.floor_height = floor_height(whole, self.contacts, names)
        self.__dict__.pop("_limits_cache", None)

    @property
    def has_guards(self) -> bool:
        """Whether the model holds what the guards of generated motion need (models written
        before the guards did not)."""
        return getattr(self, "contacts", None) is not None

    def training_clips(self) -> list[Motion]:
        """The training clips' rotations and translations as Motions.

        What the joint limits are learned from.

        Returns
        -------
        list of Motion
            One per clip, the root at its rest translation.
        """
        ends = list(self.clip_starts[1:]) + [self.train_rot.shape[0]]
        n = self.train_rot.shape[0]
        root = np.repeat(np.asarray(self.rest_root_pos, dtype=np.float64)[None], n, axis=0)
        return [Motion(self.skeleton, self.frame_time, root[a:b], self.train_rot[a:b],
                       self.train_trans[a:b]) for a, b in zip(self.clip_starts, ends)]

    def __getstate__(self) -> dict[str, Any]:
        state = self.__dict__.copy()
        state.pop("_limits_cache", None)
        return state

    def joint_limits(self) -> JointLimits:
        """:func:`mlayer.joint_limits` of the training clips (made once, kept).

        Returns
        -------
        JointLimits
            The limits.
        """
        lim = self.__dict__.get("_limits_cache")
        if lim is None:
            lim = joint_limits(self.training_clips())
            self.__dict__["_limits_cache"] = lim
        return lim

    def contacts_along(self, traj: ArrayLike) -> NDArray[np.bool_]:
        """Contacts of generated frames: those of the nearest training frames on the manifold.

        (:func:`mlayer.manifold.generate_guards.contacts_along`.)

        Parameters
        ----------
        traj : array_like, shape (n, 2)
            Manifold points of the generated frames.

        Returns
        -------
        numpy.ndarray of bool, shape (n, C)
            C = len(contact_names).
        """
        return contacts_along(self.points, self.clamp(traj), np.asarray(self.contacts),
                              1.0 / self.frame_time)

    def guard(self, motion: Motion, traj: ArrayLike
              ) -> tuple[Motion, GuardReport, NDArray[np.bool_]]:
        """The guards on a motion generated along manifold points.

        The training frames' contacts pinned (each contact point at its mean position over the
        contact), the training limits (always), the training floor.

        Parameters
        ----------
        motion : Motion
            The generated motion.
        traj : array_like, shape (n, 2)
            Its manifold points.

        Returns
        -------
        motion : Motion
            The guarded motion.
        report : GuardReport
            What the guards did.
        contacts : numpy.ndarray of bool, shape (n, C)
            The generated frames' contacts.
        """
        if not self.has_guards:
            raise InvalidArgumentError("guards: the model was written before generated motion "
                                       "had guards; fit it again, or generate without guards "
                                       "(guards=False, --no-guards)")
        c = self.contacts_along(traj)
        if c.shape[1]:
            c = split_drifting(c, contact_positions(motion, self.contact_names),
                               _PIN_DRIFT * body_height(motion),
                               round(_PIN_GAP / self.frame_time))
        floor = self.floor_height if math.isfinite(self.floor_height) else None
        out, report = guard_motion(motion, self.contact_names, c, limits=self.joint_limits(),
                                   floor=floor)
        return out, report, c

    def _set_body(self, body: int, clips: Sequence[Motion] | None = None) -> None:
        """The body joint and, when it is not the root, the translations the generated motion
        keeps: the root's and the other position channels' medians over the training frames."""
        self.body_joint = int(body)
        P = self.skeleton.trans_joints.shape[0]
        if clips is None or self.body_joint == 0:
            self.rest_root_pos = np.zeros(3)
            self.rest_trans = np.asarray(self.skeleton.offsets[self.skeleton.trans_joints],
                                         dtype=np.float64).reshape(P, 3)
            return
        self.rest_root_pos = np.median(np.concatenate([m.root_pos for m in clips]), axis=0)
        self.rest_trans = np.median(np.concatenate([m.trans for m in clips]), axis=0)

    def _body_slot(self) -> int:
        """Index of the body joint in skeleton.trans_joints (body_joint != 0)."""
        return int(np.flatnonzero(self.skeleton.trans_joints == self.body_joint)[0])

    def _targets(self, clips: Sequence[Motion], X: NDArray[np.float64]) -> NDArray[np.float64]:
        """Per frame: [body height, vx, vz (heading frame, per frame), yaw rate, J*4
        quaternions (body joint without heading), 3J positions]. The body's translation and
        heading are the root's, or on rigs with a static root those of body_joint in its
        parent's frame (its position channels and local rotation)."""
        b = self.body_joint
        parts = []
        for m in clips:
            yaw, rest = split_heading(m.rot[:, b])
            rot = m.rot.copy()
            rot[:, b] = rest
            t = body_translation(m, b)
            dp = np.diff(t, axis=0)
            dyaw = np.angle(np.exp(1j * np.diff(yaw)))
            c, s = np.cos(yaw[:-1]), np.sin(yaw[:-1])
            # world step rotated by -yaw: the step in the heading frame
            vx = c * dp[:, 0] - s * dp[:, 2]
            vz = s * dp[:, 0] + c * dp[:, 2]
            vel = np.stack([vx, vz, dyaw], axis=1)
            vel = np.vstack([vel, vel[-1:]])
            parts.append((t[:, 1:2], vel, rot))
        rot = _hemisphere(np.concatenate([p[2] for p in parts]))
        return np.hstack([np.concatenate([p[0] for p in parts]),
                          np.concatenate([p[1] for p in parts]),
                          rot.reshape(rot.shape[0], -1), X])

    # -- mapping ---------------------------------------------------------------------------------

    def clamp(self, points: ArrayLike) -> NDArray[np.float64]:
        """Points clipped to the manifold box the GRBF was fitted on.

        Parameters
        ----------
        points : array_like, shape (n, 2)
            Manifold points.

        Returns
        -------
        numpy.ndarray, shape (n, 2)
            The clipped points.
        """
        p = np.array(points, dtype=np.float64)
        for j in range(2):
            np.clip(p[:, j], self.bounds[j][0], self.bounds[j][1], out=p[:, j])
        return p

    def _split(self, Y: NDArray[np.float64]) -> dict[str, NDArray[np.float64]]:
        J = self.skeleton.n_joints
        rot = Y[:, 4:4 + 4 * J].reshape(-1, J, 4)
        rot = rot / np.linalg.norm(rot, axis=-1, keepdims=True)
        return {"height": Y[:, 0], "velocity": Y[:, 1:3], "yaw_rate": Y[:, 3],
                "rot": rot, "positions": Y[:, 4 + 4 * J:].reshape(-1, J, 3)}

    def predict(self, points: ArrayLike) -> dict[str, NDArray[np.float64]]:
        """GRBF outputs at manifold points.

        Parameters
        ----------
        points : array_like, shape (n, 2)
            Manifold points.

        Returns
        -------
        dict of str to numpy.ndarray
            ``height`` (n,), ``velocity`` (n, 2), ``yaw_rate`` (n,), ``rot`` (n, J, 4,
            renormalized, root without heading) and ``positions`` (n, J, 3: pose features,
            root at the origin, heading removed).
        """
        return self._split(self.grbf.predict(points))

    def positions(self, points: ArrayLike) -> NDArray[np.float64]:
        """Joint positions (pose features) at manifold points, as the paper maps.

        Parameters
        ----------
        points : array_like, shape (n, 2)
            Manifold points.

        Returns
        -------
        numpy.ndarray, shape (n, J, 3)
            The positions.
        """
        return self.predict(points)["positions"]

    def to_manifold(self, poses: Motion | ArrayLike) -> NDArray[np.float64]:
        """Inverse mapping: manifold points of poses.

        Parameters
        ----------
        poses : Motion or array_like, shape (n, 3J)
            Pose features, or a motion (its frames).

        Returns
        -------
        numpy.ndarray, shape (n, 2)
            The BMU's lattice position (SOM) or the PCA projection.
        """
        X = pose_features(poses) if isinstance(poses, Motion) else np.asarray(poses, np.float64)
        if X.ndim == 1:
            X = X[None, :]
        dim = 3 * self.skeleton.n_joints
        if X.ndim != 2 or X.shape[1] != dim:
            raise InvalidArgumentError(f"to_manifold: dimension mismatch, poses must be "
                                       f"(n, {dim}) pose features, got shape {X.shape}")
        if isinstance(poses, Motion) and not np.array_equal(poses.skeleton.parents,
                                                            self.skeleton.parents):
            raise InvalidArgumentError("to_manifold: the motion has another skeleton than the "
                                       "model")
        if not np.isfinite(X).all():
            raise InvalidArgumentError("to_manifold: poses contain NaN or infinite values")
        if self.manifold == "som":
            rows, cols, d = self.som_codebook.shape
            s = SOM(rows, cols, d)
            s.codebook = self.som_codebook
            return s.bmu(X).astype(np.float64)
        return (X - self.pca_mean) @ self.pca_components.T

    # -- synthesis -------------------------------------------------------------------------------

    def primitive_path(self, start: int, n_frames: int, *, noise: float = 0.0, seed: int = 0,
                       most_likely: bool = False, second_likely: bool = False,
                       allow_unseen: bool = False, rng: Rng | None = None
                       ) -> NDArray[np.int64]:
        """Primitives from a start, enough to fill n_frames at their mean durations.

        Sampled from the chain of distinct primitives (of the model's order), or following the
        most likely (equation 5) or the second most likely next primitive (paper Figure 3 (c)).
        The most likely path of a perturbed chain is paper Figure 3 (d).

        Parameters
        ----------
        start : int
            The first primitive.
        n_frames : int
            Frames to fill.
        noise : float, optional
            Perturb the chain first when > 0 (the C core's ``mlr_markov_perturb``, the draws of
            :meth:`mlayer.Markov.perturbed` for the jump model; :meth:`mlayer.Markov.walk`).
        seed : int, optional
            Seed of the perturbation and of the sampling's generator.
        most_likely, second_likely : bool, optional
            Follow the most likely or the second most likely next primitive.
        allow_unseen : bool, optional
            As for :meth:`mlayer.Markov.perturbed`.
        rng : mlayer.manifold.markov.Rng, optional
            The sampling's generator (default ``Rng(seed)``); one uniform per sampled step
            (:meth:`mlayer.Markov.walk`).

        Returns
        -------
        numpy.ndarray of int64
            The primitives.
        """
        if most_likely and second_likely:
            raise InvalidArgumentError("generate: most_likely and second_likely exclude each "
                                       "other (--most-likely, --second-likely)")
        noise = _non_negative(noise, "generate: noise")
        if not isinstance(allow_unseen, (bool, np.bool_)):
            raise InvalidArgumentError(f"allow_unseen must be True or False, got "
                                       f"{allow_unseen!r}")
        rank = 1 if most_likely else 2 if second_likely else 0
        n_frames = integer(n_frames, "generate: frames", 1)
        seed = integer(seed, "generate: seed", 0, 2**64 - 1)
        # the C core's perturbation and walk (mlr_markov_perturb, mlr_markov_path): a C program
        # gets the same path from the same model and seed (mlr_generate.h)
        return self.markov.walk(int(start), n_frames, rank=rank,
                                rng=rng if rng is not None else Rng(seed), seed=seed,
                                noise=noise, allow_unseen=bool(allow_unseen))

    def through_points(self, points: ArrayLike) -> NDArray[np.float64]:
        """Manifold points checked to be finite and on the map (the box the GRBF spans).

        Parameters
        ----------
        points : array_like, shape (K, 2)
            Row, column of the lattice; PCA: PC 1, PC 2.

        Returns
        -------
        numpy.ndarray, shape (K, 2)
            The points.

        Raises
        ------
        mlayer.InvalidArgumentError
            Naming ``through``, for points off the map or not finite.
        """
        p = np.asarray(points, dtype=np.float64) if not isinstance(points, str) else None
        if p is None or p.ndim != 2 or p.shape[1] != 2 or p.shape[0] < 1:
            raise InvalidArgumentError(f"option through: need points (K, 2), K >= 1, got "
                                       f"{points!r}")
        if not np.isfinite(p).all():
            raise InvalidArgumentError("option through: points must be finite")
        (r0, r1), (c0, c1) = self.bounds
        for i, (r, c) in enumerate(p):
            if not (r0 - 1e-9 <= r <= r1 + 1e-9 and c0 - 1e-9 <= c <= c1 + 1e-9):
                what = "rows" if self.manifold == "som" else "PC 1"
                other = "columns" if self.manifold == "som" else "PC 2"
                raise InvalidArgumentError(
                    f"option through: point {i} (row {r:g}, column {c:g}) is outside the map "
                    f"({what} {r0:g} .. {r1:g}, {other} {c0:g} .. {c1:g})")
        if p.shape[0] > 1 and (np.linalg.norm(np.diff(p, axis=0), axis=1) == 0).any():
            raise InvalidArgumentError("option through: two consecutive points are the same")
        return p

    def key_points(self, keys: Sequence[tuple[int | str | Motion, int]]) -> NDArray[np.float64]:
        """Manifold points of key frames.

        Parameters
        ----------
        keys : sequence of (clip, frame)
            ``clip`` a training clip's index or name (``clip_names``) or a Motion of the
            model's skeleton (its frame's BMU, :meth:`to_manifold`), ``frame`` an index into
            that clip.

        Returns
        -------
        numpy.ndarray, shape (K, 2)
            The points.
        """
        if isinstance(keys, (str, bytes)) or not hasattr(keys, "__len__") or len(keys) == 0:
            raise InvalidArgumentError(f"option keys: need a list of (clip, frame) pairs, got "
                                       f"{keys!r}")
        out = []
        for key in keys:
            if not isinstance(key, (tuple, list)) or len(key) != 2:
                raise InvalidArgumentError(f"option keys: {key!r} is not a (clip, frame) pair")
            clip, frame = key
            if isinstance(clip, Motion):
                diff = skeleton_difference(clip.skeleton, self.skeleton, "the model")
                if diff is not None:  # (join_skeletons renames a clip of other names)
                    raise InvalidArgumentError(f"option keys: the key clip has another skeleton "
                                               f"than the model: {diff}")
                n, first, what = clip.n_frames, None, "the key clip"
            else:
                first, n = self.clip_frames(clip)
                what = f"clip {clip!r}"
            f = integer(frame, "option keys: frame", 0)
            if f >= n:
                raise InvalidArgumentError(f"option keys: frame {f} is beyond {what} ({n} "
                                           f"frames, 0 .. {n - 1})")
            # a Motion's features as a whole clip (its up axis and heading from all frames)
            out.append(self.to_manifold(clip)[f] if first is None else self.points[first + f])
        return np.array(out, dtype=np.float64)

    def spline(self, knots: ArrayLike, times: ArrayLike, n_frames: int, *,
               stiffness: float = 1e-3) -> NDArray[np.float64]:
        """The LGS smoothing spline (second-difference prior) through knots.

        Parameters
        ----------
        knots : array_like, shape (K, 2)
            Manifold points.
        times : array_like, shape (K,)
            Their fractional frames.
        n_frames : int
            Frames to sample.
        stiffness : float, optional
            ``lam^2 sigma^2``.

        Returns
        -------
        numpy.ndarray, shape (n_frames, 2)
            The spline.
        """
        knots = np.asarray(knots, dtype=np.float64)
        t = np.asarray(times, dtype=np.float64)
        if knots.shape[0] == 1:
            return np.repeat(knots, n_frames, axis=0)
        return lgs(knots, lam=math.sqrt(stiffness), sigma=1.0, order=2, t=t, n_out=n_frames)

    def generate(self, n_frames: int, *, start_frame: int | None = None, start: int | None = None,
                 path: Sequence[int] | None = None, key_poses: Motion | ArrayLike | None = None,
                 through: ArrayLike | None = None,
                 keys: Sequence[tuple[int | str | Motion, int]] | None = None,
                 noise: float = 0.0, seed: int = 0, most_likely: bool = False,
                 second_likely: bool = False, allow_unseen: bool = False, smooth: float = 2.0,
                 guards: bool = True, return_info: bool = False
                 ) -> Any:
        """Synthesize n_frames frames.

        Paths given on the manifold (at most one of them): ``through``, ``keys``,
        ``key_poses``. Otherwise the primitives' path from a start frame
        (:meth:`primitive_path`: sampled, or most_likely / second_likely; noise, seed and
        allow_unseen perturb the chain).

        Knots of the manifold path: the manifold point of training frame ``start_frame``
        followed by the centres of the primitives of ``path`` (default :meth:`primitive_path`:
        Markov samples with perturbation noise, or equation 5 when most_likely) spaced by
        their mean durations; or, with key_poses, their manifold points (:meth:`to_manifold`)
        spread evenly over the frames. The LGS spline through the knots, clipped to the
        manifold box, is mapped to poses by the GRBF, smoothed by the LGS with lam = smooth,
        quaternions renormalized; root height, turning and forward motion come from the
        mapping too.

        Parameters
        ----------
        n_frames : int
            Frames to generate, at least 3 (the spline and its smoothing are order-2 LGS).
        start_frame : int, optional
            The training frame to start from (default a seeded random frame).
        start : int, optional
            The first primitive.
        path : sequence of int, optional
            The primitives to visit.
        key_poses : Motion or array_like, optional
            Pose features or a motion whose frames are the knots.
        through : array_like, shape (K, 2), optional
            Points on the map (:meth:`through_points`), spaced by their distance along the
            polyline (paper Figure 4).
        keys : sequence of (clip, frame), optional
            Key frames of the training clips (or of a Motion, :meth:`key_points`), spread
            evenly over the frames (paper Figure 5).
        noise, seed, most_likely, second_likely, allow_unseen
            As for :meth:`primitive_path`.
        smooth : float, optional
            The lam of the LGS that smooths the mapped poses.
        guards : bool, optional
            The plausibility guards of the training clips (:meth:`guard`): the contacts of the
            training frames nearest to each generated frame's manifold point pinned by IK, the
            training clips' joint limits, their floor. False gives the raw mapping.
        return_info : bool, optional
            Also return a dict with the manifold path (``trajectory``), ``knots``, ``times``,
            the primitive sequence (``primitives``), ``contact_names``/``contacts`` (the
            generated frames' contacts) and ``guards`` (a
            :class:`mlayer.pipeline.pipeline.GuardReport`, None when the guards did not run).

        Returns
        -------
        Motion or (Motion, dict)
            The generated motion, with the info when ``return_info``.
        """
        if not isinstance(guards, (bool, np.bool_)):
            raise InvalidArgumentError(f"generate: guards must be True or False, got "
                                       f"{guards!r}")
        if guards and not self.has_guards:
            raise InvalidArgumentError("generate: the model was written before generated motion "
                                       "had guards; fit it again, or generate without guards "
                                       "(guards=False, --no-guards)")
        # the spline and the smoothing are order-2 LGS: 3 frames at least (2 failed in the LGS)
        n_frames = integer(n_frames, "generate: frames", 3)
        smooth = _non_negative(smooth, "generate: smooth")
        noise = _non_negative(noise, "generate: noise")
        seed = integer(seed, "generate: seed", 0, 2**64 - 1)
        # the mapping's outputs, their smoothing and the guards: a few copies of n_frames poses
        per_frame = getattr(self.grbf, "n_outputs_", 0) + 8 * self.skeleton.n_joints
        _arrays.check_memory(64.0 * n_frames * per_frame, f"generate: n_frames={n_frames}")
        n = self.points.shape[0]
        given = [nm for nm, v in (("path", path), ("key_poses", key_poses),
                                  ("through", through), ("keys", keys)) if v is not None]
        if len(given) > 1:
            raise InvalidArgumentError(f"generate: {' and '.join(given)} exclude each other")
        if most_likely and second_likely:
            raise InvalidArgumentError("generate: most_likely and second_likely exclude each "
                                       "other (--most-likely, --second-likely)")
        if through is not None or keys is not None:
            knots = self.through_points(through) if through is not None \
                else self.key_points(keys or [])
            if knots.shape[0] > n_frames:
                raise InvalidArgumentError(f"generate: {knots.shape[0]} points for {n_frames} "
                                           f"frames (option frames)")
            if knots.shape[0] == 1:
                times = np.zeros(1)
            elif through is not None:
                arc = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(knots, axis=0), axis=1))]
                times = arc * (n_frames - 1) / arc[-1]
            else:
                times = np.linspace(0, n_frames - 1, knots.shape[0])
            seq = np.array([int(np.argmin(((self.centers - p) ** 2).sum(1))) for p in knots])
        elif key_poses is not None:
            knots = self.to_manifold(key_poses)
            if knots.shape[0] < 1:
                raise InvalidArgumentError("generate: no key poses")
            times = np.linspace(0, n_frames - 1, knots.shape[0]) if knots.shape[0] > 1 \
                else np.zeros(1)
            seq = np.array([int(np.argmin(((self.centers - p) ** 2).sum(1))) for p in knots])
        else:
            # one generator for the start frame and the walk, as the C runtime draws them
            rng = Rng(seed)
            if start_frame is None:
                start_frame = rng.below(n)
            if isinstance(start_frame, bool) or not isinstance(start_frame, (int, np.integer)) \
                    or not 0 <= start_frame < n:
                raise InvalidArgumentError(f"generate: start frame {start_frame!r} out of range "
                                           f"(the model has {n} training frames, 0 .. {n - 1})")
            first = int(self.labels[start_frame]) if start is None else int(start)
            if path is None:
                seq = self.primitive_path(first, n_frames, noise=noise, seed=seed,
                                          most_likely=most_likely, second_likely=second_likely,
                                          allow_unseen=allow_unseen, rng=rng)
            else:
                seq = np.asarray(path, dtype=np.int64)
                if seq.ndim != 1 or seq.size == 0 or seq.min() < 0 \
                        or seq.max() >= self.centers.shape[0]:
                    raise InvalidArgumentError(f"generate: path must list primitives 0 .. "
                                               f"{self.centers.shape[0] - 1}")
            dur = np.maximum(self.markov.run_length, 1.0)
            knots = np.vstack([self.points[start_frame], self.centers[seq[1:]]])
            steps = (dur[seq[:-1]] + dur[seq[1:]]) / 2.0
            times = np.r_[0.0, np.cumsum(steps)]
            if path is not None and times[-1] > 0:
                times *= (n_frames - 1) / times[-1]  # a given path fills the frames
            # cut at the last frame: interpolate the knot where the time reaches n_frames - 1
            last = n_frames - 1
            if times[-1] > last:
                i = int(np.searchsorted(times, last))
                a = (last - times[i - 1]) / (times[i] - times[i - 1])
                end = knots[i - 1] + a * (knots[i] - knots[i - 1])
                knots = np.vstack([knots[:i], end])
                times = np.r_[times[:i], last]
                seq = seq[:i + 1]
        if knots.shape[0] > 1 and np.any(np.diff(times) <= 0):
            raise InvalidArgumentError("generate: more key poses than frames")
        traj = self.clamp(self.spline(knots, times, n_frames))
        motion = self.motion_along(traj, smooth=smooth)
        report, contacts = None, None
        if guards:
            motion, report, contacts = self.guard(motion, traj)
        if return_info:
            if contacts is None and self.has_guards:
                contacts = self.contacts_along(traj)
            return motion, {"trajectory": traj, "knots": knots, "times": times,
                            "primitives": seq, "guards": report,
                            "contact_names": list(getattr(self, "contact_names", [])),
                            "contacts": contacts}
        return motion

    def motion_along(self, traj: ArrayLike, *, smooth: float = 2.0) -> Motion:
        """The motion whose frames the GRBF maps from manifold points.

        Parameters
        ----------
        traj : array_like, shape (n, 2)
            Manifold points.
        smooth : float, optional
            The lam of the LGS that smooths the mapped poses.

        Returns
        -------
        Motion
            The motion.
        """
        traj = np.asarray(traj, dtype=np.float64)
        smooth = _non_negative(smooth, "motion_along: smooth")
        Y = self.grbf.predict(traj)
        if smooth > 0 and Y.shape[0] > 2:
            Y = lgs(Y, lam=smooth, sigma=1.0, order=2)
        out = self._split(Y)
        yaw = np.r_[0.0, np.cumsum(out["yaw_rate"][:-1])]
        c, s = np.cos(yaw), np.sin(yaw)
        v = out["velocity"]
        step = np.stack([c * v[:, 0] + s * v[:, 1], -s * v[:, 0] + c * v[:, 1]], axis=1)
        xz = np.vstack([np.zeros((1, 2)), np.cumsum(step[:-1], axis=0)])
        body_pos = np.stack([xz[:, 0], out["height"], xz[:, 1]], axis=1)
        b = getattr(self, "body_joint", 0)
        rot = out["rot"]
        rot[:, b] = quat.mul(heading_quat(yaw), rot[:, b])
        rot = quat.normalize(rot)
        if b == 0:
            return Motion(self.skeleton, self.frame_time, body_pos, rot)
        # a static root above the body joint: the root and the other position channels keep
        # their training values, the body joint's position channels walk
        n = body_pos.shape[0]
        trans = np.repeat(self.rest_trans[None], n, axis=0)
        trans[:, self._body_slot()] = body_pos
        root_pos = np.repeat(self.rest_root_pos[None], n, axis=0)
        return Motion(self.skeleton, self.frame_time, root_pos, rot, trans)

    # -- persistence -----------------------------------------------------------------------------

    def _load_dynamics(self, z: Any, fmt: int) -> None:
        """The Markov model, the k criteria and the clip names of a model file; format 1 files
        (before orders and criteria) load as order 1, clips named by their index."""
        if fmt == 1:
            self.markov = Markov(z["P"], z["counts"], z["run_length"])
            self.criterion, self.cluster, self.criteria = "elbow", "kmeans", None
            self.cluster_on = "manifold"
            self.k_source = None
            self.clip_names = [str(i) for i in range(len(z["clip_starts"]))]
            self.order_loglik = {}
            return
        self.markov = Markov(z["P"], z["counts"], z["run_length"],
                             order=int(z["markov_order"]), min_count=int(z["markov_min_count"]),
                             contexts=contexts_from_arrays(z["markov_ctx_keys"],
                                                           z["markov_ctx_counts"]))
        self.criterion, self.cluster = str(z["criterion"]), str(z["cluster"])
        self.cluster_on = str(z["cluster_on"]) if "cluster_on" in z else "manifold"
        self.k_source = (str(z["k_source"]) or None) if "k_source" in z else None
        self.clip_names = [str(v) for v in z["clip_names"]]
        self.order_loglik = {int(o): (float(v), int(m)) for o, v, m in z["order_loglik"]}
        self.criteria = None
        if "crit_ks" in z:
            picks = dict(zip(("elbow", "silhouette", "bic"), (int(v) for v in z["crit_picks"])))
            self.criteria = KCriteria(z["crit_ks"], z["crit_inertia"], z["crit_silhouette"],
                                      z["crit_bic"], picks, ())

    def save(self, path: str | os.PathLike[str]) -> None:
        """Write the model as a .npz file (numpy arrays only, no pickle), atomically.

        Parameters
        ----------
        path : str or os.PathLike
            The file.
        """
        sk = self.skeleton
        arrays = dict(
            format=np.int64(_FORMAT), manifold=np.str_(self.manifold),
            joint_names=np.array(sk.joint_names), parents=sk.parents, offsets=sk.offsets,
            channels=np.array(sk.channels), end_site_parents=sk.end_site_parents,
            end_site_offsets=sk.end_site_offsets, frame_time=np.float64(self.frame_time),
            points=self.points, clip_starts=self.clip_starts, labels=self.labels,
            centers=self.centers, P=self.markov.P, counts=self.markov.counts,
            run_length=self.markov.run_length, bounds=np.array(self.bounds),
            elbow_ks=self.elbow_ks, elbow_inertia=self.elbow_inertia,
            grbf_kernel=np.str_(self.grbf.kernel), grbf_centers=self.grbf.centers_,
            grbf_lattice=np.array(self.grbf.lattice), grbf_coef=self.grbf.coef_,
            grbf_width=np.float64(getattr(self.grbf, "width_", 0.0)),
            fit_error=np.float64(self.fit_error), body_joint=np.int64(self.body_joint),
            rest_root_pos=self.rest_root_pos, rest_trans=self.rest_trans)
        K, R = self.markov.context_arrays()
        arrays.update(markov_order=np.int64(self.markov.order),
                      markov_min_count=np.int64(self.markov.min_count), markov_ctx_keys=K,
                      markov_ctx_counts=R, criterion=np.str_(self.criterion),
                      k_source=np.str_(self.k_source or ""),
                      cluster=np.str_(self.cluster), cluster_on=np.str_(self.cluster_on),
                      clip_names=np.array(self.clip_names, dtype=np.str_),
                      order_loglik=np.array([[o, *self.order_loglik[o]]
                                             for o in sorted(self.order_loglik)]).reshape(-1, 3))
        c = self.criteria
        if c is not None:
            arrays.update(crit_ks=c.ks, crit_inertia=c.inertia, crit_silhouette=c.silhouette,
                          crit_bic=c.bic, crit_picks=np.array([c.picks[q] for q in
                                                               ("elbow", "silhouette", "bic")]))
        if self.has_guards:
            arrays.update(contact_names=np.array(self.contact_names, dtype=np.str_),
                          contacts=np.asarray(self.contacts).astype(np.uint8),
                          floor_height=np.float64(self.floor_height), train_rot=self.train_rot,
                          train_trans=self.train_trans)
        if self.manifold == "som":
            arrays["som_codebook"] = self.som_codebook
        else:
            arrays["pca_mean"], arrays["pca_components"] = self.pca_mean, self.pca_components
        with atomic_output(path, suffix=".npz") as tmp:
            with open(tmp, "wb") as f:
                np.savez_compressed(f, **arrays)

    def runtime_bytes(self) -> bytes:
        """The model in the binary format of generation at run time (docs/model-format.md),
        what the C core's ``mlr_gen_model_load`` reads.

        Returns
        -------
        bytes
            The file's contents.
        """
        sk = self.skeleton
        mk = self.markov.c_arrays()
        names = b"".join(str(n).encode("utf-8") + b"\0" for n in sk.joint_names)
        f64, i64 = np.dtype("<f8"), np.dtype("<i8")
        fields: list[tuple[str, Any]] = [
            ("frame_time", np.array([self.frame_time], f64)),
            ("joint_names", np.frombuffer(names, np.uint8)),
            ("parents", np.asarray(sk.parents).astype(i64)),
            ("body_joint", np.array([getattr(self, "body_joint", 0)], i64)),
            ("points", np.asarray(self.points, f64).reshape(-1, 2)),
            ("labels", np.asarray(self.labels).astype(i64)),
            ("centers", np.asarray(self.centers, f64).reshape(-1, 2)),
            ("bounds", np.array(self.bounds, f64).reshape(2, 2)),
            ("jumps", mk["jumps"].astype(f64)),
            ("run_length", mk["run_length"].astype(f64)),
            ("markov", np.array([mk["order"], mk["min_count"]], i64)),
            ("context_keys", mk["context_keys"].astype(i64).reshape(-1, mk["order"])),
            ("context_seen", mk["context_seen"].astype(f64)),
            ("context_probs", mk["context_probs"].astype(f64).reshape(-1, self.markov.n_states)),
            ("grbf_kernel", np.array([0 if self.grbf.kernel == "thin_plate" else 1], i64)),
            ("grbf_width", np.array([float(getattr(self.grbf, "width_", 0.0) or 0.0)], f64)),
            ("grbf_centers", np.asarray(self.grbf.centers_, f64)),
            ("grbf_coef", np.asarray(self.grbf.coef_, f64))]
        if self.manifold == "som":
            rows, cols, d = self.som_codebook.shape
            fields += [("som_codebook", np.asarray(self.som_codebook, f64).reshape(-1, d)),
                       ("som_lattice", np.array([rows, cols], i64))]
        if self.has_guards:
            cn = b"".join(str(n).encode("utf-8") + b"\0" for n in self.contact_names)
            fields += [("contact_names", np.frombuffer(cn, np.uint8)),
                       ("contacts", np.asarray(self.contacts).astype(np.uint8).reshape(
                           self.points.shape[0], -1)),
                       ("floor_height", np.array([self.floor_height], f64))]
        body = bytearray()
        for name, a in fields:
            a = np.ascontiguousarray(a)
            dims = (a.shape[0], a.shape[1] if a.ndim == 2 else 1)
            kind = 1 if a.dtype == f64 else 2 if a.dtype == i64 else 3
            body += name.encode("ascii").ljust(24, b"\0")
            body += struct.pack("<IIQQ", kind, a.ndim, *dims)
            data = a.tobytes()
            body += data + b"\0" * (-len(data) % 8)
        skel = names + np.asarray(sk.parents).astype(i64).tobytes()
        head = b"MLRGEN\0\0" + struct.pack("<IIIIQQQ", RUNTIME_FORMAT, 0x01020304,
                                           int(lib.mlr_version_number()), len(fields),
                                           64 + len(body), _fnv1a(skel), zlib.crc32(body))
        return bytes(head.ljust(64, b"\0") + body)

    def save_runtime(self, path: str | os.PathLike[str]) -> None:
        """Write :meth:`runtime_bytes` to a file, atomically: the model a C program loads with
        ``mlr_gen_model_load_file`` to generate frames without Python (mlr_generate.h).

        Parameters
        ----------
        path : str or os.PathLike
            The file.
        """
        data = self.runtime_bytes()
        with atomic_output(path, suffix=".mlrgen") as tmp:
            with open(tmp, "wb") as f:
                f.write(data)

    @classmethod
    def load(cls, path: str | os.PathLike[str]) -> PrimitiveModel:
        """Read a model written by :meth:`save`.

        The file's first bytes are checked before numpy reads it, and nothing is unpickled.

        Parameters
        ----------
        path : str or os.PathLike
            A .npz file.

        Returns
        -------
        PrimitiveModel
            The model.

        Raises
        ------
        mlayer.MlayerIOError
            With one line saying a .npz model is expected, for anything else (a BVH file, a
            pickle, a .npy array).
        """
        try:
            with open(path, "rb") as f:
                head = f.read(512)
        except OSError as e:
            raise MlayerIOError(f"{path}: cannot read a model ({e.strerror or e})") from None
        if not head.startswith(b"PK\x03\x04"):  # a .npz is a zip archive
            what = "a BVH file" if head.lstrip().upper().startswith(b"HIERARCHY") else \
                "a .npy array" if head.startswith(b"\x93NUMPY") else \
                "an empty file" if not head else "not a zip archive"
            raise MlayerIOError(f"{path}: not a primitives model ({what}); expected the .npz "
                                "file `mlayer primitives` writes")
        try:
            z = np.load(path, allow_pickle=False)
        except (OSError, ValueError) as e:
            raise MlayerIOError(f"{path}: cannot read a model ({e})") from None
        with z:
            try:
                fmt = int(z["format"])
                if fmt not in _FORMATS:
                    raise MlayerIOError(f"{path}: model format {fmt}, expected one of "
                                        f"{', '.join(map(str, _FORMATS))}")
                self = cls()
                with _attrs.building(self):  # the read-only attributes set here
                    self.skeleton = Skeleton([str(s) for s in z["joint_names"]], z["parents"],
                                             z["offsets"], [str(s) for s in z["channels"]],
                                             z["end_site_parents"], z["end_site_offsets"])
                    self.manifold = str(z["manifold"])
                    self.frame_time = float(z["frame_time"])
                    for name in ("points", "clip_starts", "labels", "centers", "elbow_ks",
                                 "elbow_inertia"):
                        setattr(self, name, z[name])
                    self.bounds = tuple(tuple(float(v) for v in b) for b in z["bounds"])
                    self._load_dynamics(z, fmt)
                    g = GRBF(str(z["grbf_kernel"]),
                             cast(tuple[int, int], tuple(int(v) for v in z["grbf_lattice"])),
                             bounds=self.bounds)
                    with _attrs.building(g):
                        g.centers_, g.coef_, g._vector = z["grbf_centers"], z["grbf_coef"], False
                        g.bounds_ = self.bounds
                        g.width_ = float(z["grbf_width"])
                        g.n_outputs_ = g.coef_.shape[1]
                    self.grbf = g
                    self.fit_error = float(z["fit_error"])
                    # models written before the body joint was stored drive the root
                    self._set_body(int(z["body_joint"]) if "body_joint" in z else 0)
                    if self.body_joint != 0:
                        self.rest_root_pos = np.asarray(z["rest_root_pos"], dtype=np.float64)
                        self.rest_trans = np.asarray(z["rest_trans"], dtype=np.float64)
                    # models written before the guards of generated motion have no contacts
                    self.contacts = None
                    if "contacts" in z:
                        self.contact_names = [str(v) for v in z["contact_names"]]
                        self.contacts = np.asarray(z["contacts"]).astype(bool).reshape(
                            self.points.shape[0], len(self.contact_names))
                        self.floor_height = float(z["floor_height"])
                        self.train_rot = np.asarray(z["train_rot"], dtype=np.float64)
                        self.train_trans = np.asarray(z["train_trans"], dtype=np.float64)
                    if self.manifold == "som":
                        self.som_codebook = z["som_codebook"]
                    else:
                        self.pca_mean, self.pca_components = z["pca_mean"], z["pca_components"]
            except KeyError as e:
                raise MlayerIOError(f"{path}: not an mlayer primitives model (missing {e})") \
                    from None
        return self
