"""AMASS / SMPL motions: ``.npz`` files of axis-angle poses and root translations.

AMASS (Mahmood et al. 2019) stores each clip as a numpy ``.npz`` archive: ``poses`` (F, 3K),
one rotation vector (axis times angle, radians) per joint of the body model in the model's
joint order, local to the parent, the first the global orientation of the pelvis;
``trans`` (F, 3) in metres; ``mocap_framerate`` (SMPL-H files) or ``mocap_frame_rate``
(SMPL-X files); optionally ``betas``, ``gender``, ``surface_model_type`` and more. The world
is Z-up.

:func:`read_amass` turns one into a :class:`~mlayer.Motion` on the SMPL body tree (22 joints)
or the SMPL-H tree (52: the body and both hands), with the rest offsets of
:mod:`mlayer.io.smpl` (or the joint locations the caller gives); :func:`write_amass` is the
inverse for motions on those trees. Files are read without pickle
(``numpy.load(allow_pickle=False)``): an archive that needs it is refused.
"""
from __future__ import annotations

import os
import tokenize
import zipfile
import zlib
from typing import Any, Literal, NamedTuple, overload

import numpy as np

from ..model import quat
from . import smpl
from .._files import atomic_output
from ..errors import Error, InvalidArgumentError, MlayerIOError, ParseError
from ..model.motion import MAX_FRAME_TIME, MIN_FRAME_TIME, Motion, Skeleton

__all__ = ["read_amass", "write_amass", "AmassBody", "MODELS"]

MODELS = ("smpl", "smplh", "smplx")
"""The body models :func:`read_amass` takes (``model=``), besides ``"auto"``."""

# columns of poses: the width per model, the hands' [first, end) where there are hands; the
# body is always [0, 66) (the pelvis first)
_WIDTH = {"smpl": 72, "smplh": 156, "smplx": 165}
_HANDS = {"smplh": (66, 156), "smplx": (75, 165)}  # SMPL-X: jaw [66, 69), eyes [69, 75)
_BODY = 66


class AmassBody(NamedTuple):
    """What an AMASS file says about the body (``read_amass(..., return_body=True)``).

    To pass back to :func:`write_amass`:
    ``write_amass(m, out, betas=body.betas, gender=body.gender)``.

    Parameters
    ----------
    betas : numpy.ndarray or None
        The shape coefficients.
    gender : str or None
        ``gender`` as stored.
    model : str
        The body model the poses were read as.
    """

    betas: np.ndarray | None
    """The shape coefficients (1-D), or None when the file has none."""
    gender: str | None
    """``gender`` as stored ("male", "female", "neutral"), or None when absent or not a
    plain string (an object array would need pickle)."""
    model: str
    """The body model the poses were read as: "smpl", "smplh" or "smplx"."""


MAX_BYTES = 1 << 30
"""The default ``max_bytes`` of :func:`read_amass`: the most its members may expand to."""


def _gender(z: Any) -> str | None:
    if "gender" not in z.files:
        return None
    try:
        g = z["gender"]
    except (ValueError, OSError, EOFError, zipfile.BadZipFile):
        return None
    if not isinstance(g, np.ndarray) or g.dtype.kind not in "US" or g.size != 1:
        return None
    v = g.reshape(()).item()
    return v.decode("utf-8", "replace") if isinstance(v, bytes) else str(v)


def _fail(path: str, reason: str) -> ParseError:
    return ParseError(f"{path}: {reason}", path=path)


def _load(path: str) -> Any:
    try:
        z = np.load(path, allow_pickle=False)
    except OSError as e:
        if isinstance(e, (FileNotFoundError, PermissionError, IsADirectoryError)):
            raise MlayerIOError(f"read_amass: cannot open {path}: {e.strerror or e}") from e
        raise _fail(path, f"not a numpy .npz archive ({e})") from None
    except (ValueError, EOFError, zipfile.BadZipFile, NotImplementedError, zlib.error) as e:
        raise _fail(path, f"not a numpy .npz archive ({e})") from None
    if not isinstance(z, np.lib.npyio.NpzFile):
        raise _fail(path, "a single .npy array, not an .npz archive of named arrays")
    return z


def _declared_size_ok(z: Any, key: str) -> bool:
    """Whether the array's header declares no more bytes than its zip member holds (a
    hostile header must not make numpy allocate terabytes before the read fails)."""
    name = key if key in z.zip.namelist() else key + ".npy"
    try:
        info = z.zip.getinfo(name)
        with z.zip.open(name) as f:
            version = np.lib.format.read_magic(f)
            read = (np.lib.format.read_array_header_1_0 if version == (1, 0)
                    else np.lib.format.read_array_header_2_0)
            shape, _, dtype = read(f)
            header = f.tell()
    except Exception:  # noqa: BLE001 - anything wrong here is reported by the read itself
        return True
    if dtype.hasobject:
        return True  # refused by the read (pickle)
    return int(np.prod(shape, dtype=object)) * dtype.itemsize <= info.file_size - header


def _get(z: Any, path: str, key: str) -> np.ndarray:
    if not _declared_size_ok(z, key):
        raise _fail(path, f"{key!r} declares a larger array than the file holds (damaged)")
    try:
        a = z[key]
    except ValueError as e:  # object arrays need pickle
        raise _fail(path, f"{key!r} cannot be read without pickle ({e}); mlayer does not "
                          "unpickle files") from None
    except (OSError, EOFError, zipfile.BadZipFile) as e:
        raise _fail(path, f"{key!r} is damaged ({e})") from None
    if not isinstance(a, np.ndarray):  # a member that is not .npy: its raw bytes
        raise _fail(path, f"{key!r} is not a numpy array (a raw pickle or other data); "
                          "mlayer does not unpickle files")
    return a


def _numeric(a: np.ndarray, path: str, key: str, ndim: int) -> np.ndarray:
    if not (np.issubdtype(a.dtype, np.floating) or np.issubdtype(a.dtype, np.integer)):
        raise _fail(path, f"{key!r} must hold numbers, got dtype {a.dtype}")
    if a.ndim != ndim:
        raise _fail(path, f"{key!r} must have {ndim} dimension{'s' * (ndim > 1)}, got shape "
                          f"{a.shape}")
    a = np.asarray(a, dtype=np.float64, order="C")  # keeps 0-d arrays 0-d
    if not np.isfinite(a).all():
        bad = np.argwhere(~np.isfinite(a))[0]
        raise _fail(path, f"{key!r} has a non-finite value at {tuple(int(i) for i in bad)}")
    return a


def _framerate(z: Any, path: str) -> float:
    keys = [k for k in ("mocap_framerate", "mocap_frame_rate") if k in z.files]
    if not keys:
        raise _fail(path, "no frame rate: neither 'mocap_framerate' nor 'mocap_frame_rate'")
    a = _get(z, path, keys[0])
    if a.size != 1:
        raise _fail(path, f"{keys[0]!r} must be one number, got shape {a.shape}")
    fps = float(_numeric(a.reshape(()), path, keys[0], 0))
    if not (fps > 0 and MIN_FRAME_TIME <= 1.0 / fps <= MAX_FRAME_TIME):
        raise _fail(path, f"{keys[0]!r} must be positive, {1 / MAX_FRAME_TIME:g} .. "
                          f"{1 / MIN_FRAME_TIME:g} frames per second, got {fps:g}")
    return fps


def _model_of(z: Any, path: str, width: int, model: str) -> str:
    if model == "auto" and "surface_model_type" in z.files:
        t = _get(z, path, "surface_model_type")
        if t.dtype.kind in "US" and t.size == 1:
            name = str(t.reshape(()).item())
            name = name.decode("ascii", "replace") if isinstance(name, bytes) else name
            name = name.lower().split("_")[0]  # "smplx_locked_head" and the like
            if name in MODELS:
                model = name
    if model == "auto":
        by_width = {72: "smpl", 66: "smpl", 156: "smplh", 165: "smplx"}
        if width not in by_width:
            raise _fail(path, f"'poses' has {width} columns per frame: not SMPL (72, or 66 for "
                              "the body alone), SMPL-H (156) or SMPL-X (165)")
        return by_width[width]
    ok = (66, 72) if model == "smpl" else (_WIDTH[model],)
    if width not in ok:
        raise _fail(path, f"'poses' has {width} columns per frame, {model} files have "
                          f"{' or '.join(map(str, ok))}")
    return model


def _poses(z: Any, path: str) -> np.ndarray:
    """(F, W) poses: the ``poses`` key, or AMASS's split keys (root_orient, pose_body and
    optionally pose_hand) when it is absent."""
    if "poses" in z.files:
        return _numeric(_get(z, path, "poses"), path, "poses", 2)
    if "root_orient" in z.files and "pose_body" in z.files:
        parts = [_numeric(_get(z, path, k), path, k, 2) for k in ("root_orient", "pose_body")]
        if "pose_hand" in z.files:
            parts.append(_numeric(_get(z, path, "pose_hand"), path, "pose_hand", 2))
        for k, w, p in zip(("root_orient", "pose_body", "pose_hand"), (3, 63, 90), parts):
            if p.shape[1] != w or p.shape[0] != parts[0].shape[0]:
                raise _fail(path, f"{k!r} must be ({parts[0].shape[0]}, {w}), got {p.shape}")
        return np.concatenate(parts, axis=1)  # 66 columns (the body) or SMPL-H's 156
    raise _fail(path, "no 'poses' (nor 'root_orient' and 'pose_body'): not an AMASS file")


def _rest_offsets(joint_positions: Any, names: tuple[str, ...], parents: tuple[int, ...],
                  default: np.ndarray, model: str) -> np.ndarray:
    if joint_positions is None:
        return np.array(default)
    jp = np.asarray(joint_positions, dtype=np.float64) \
        if not isinstance(joint_positions, np.ndarray) else joint_positions.astype(np.float64)
    J = len(names)
    if jp.ndim != 2 or jp.shape[1] != 3:
        raise InvalidArgumentError(f"read_amass: joint_positions must be (J, 3), got {jp.shape}")
    n = jp.shape[0]
    if n == J:
        pass
    elif J == 22 and n in (24, 52, 55):  # SMPL's 24 (hands dropped), SMPL-H's 52, SMPL-X's 55
        jp = jp[:22]
    elif J == 52 and n == 55:  # SMPL-X: drop jaw and eyes
        jp = np.concatenate([jp[:22], jp[25:]])
    else:
        raise InvalidArgumentError(
            f"read_amass: joint_positions has {n} rows; the {model} tree read here has {J} "
            f"joints (give {J} rows in SMPL order, or the model's full joint set)")
    if not np.isfinite(jp).all():
        raise InvalidArgumentError("read_amass: joint_positions contains NaN or infinite values")
    off = jp - jp[np.maximum(np.asarray(parents), 0)]
    off[0] = jp[0]
    return off


def _arrays(z: Any, path: str, max_bytes: int, model: str) -> tuple[Any, ...]:
    """read_amass's arrays of an open archive: poses, trans, fps, betas, model, gender."""
    total = sum(info.file_size for info in z.zip.infolist())
    if total > max_bytes:
        raise _fail(path, f"its members expand to {total} bytes, more than max_bytes="
                          f"{max_bytes} (a zip bomb, or pass a larger max_bytes)")
    poses = _poses(z, path)
    if "trans" not in z.files:
        raise _fail(path, "no 'trans' (F x 3 root translations)")
    trans = _numeric(_get(z, path, "trans"), path, "trans", 2)
    fps = _framerate(z, path)
    betas = None
    if "betas" in z.files:
        b = _get(z, path, "betas")
        betas = _numeric(b.reshape(-1) if b.ndim <= 2 else b, path, "betas", 1)
    model = _model_of(z, path, poses.shape[1], model)
    gender = _gender(z)
    return poses, trans, fps, betas, model, gender


@overload
def read_amass(path: str | os.PathLike[str], *, joint_positions: Any = None,
               model: str = "auto", return_body: Literal[False] = False,
               max_bytes: int = MAX_BYTES) -> Motion: ...
@overload
def read_amass(path: str | os.PathLike[str], *, joint_positions: Any = None,
               model: str = "auto", return_body: Literal[True],
               max_bytes: int = MAX_BYTES) -> tuple[Motion, AmassBody]: ...
def read_amass(path: str | os.PathLike[str], *, joint_positions: Any = None,
               model: str = "auto", return_body: bool = False,
               max_bytes: int = MAX_BYTES) -> Motion | tuple[Motion, AmassBody]:
    """Read an AMASS-style ``.npz`` file into a Motion on the SMPL or SMPL-H tree.

    Parameters
    ----------
    path : str or os.PathLike
        The ``.npz`` archive (read without pickle).
    joint_positions : array_like, shape (J, 3), optional
        Rest joint locations of the subject in SMPL order, in metres, in the model's template
        frame (e.g. the body model's ``J_regressor`` applied to its shaped template): J is the
        tree's 22 or 52 joints, or the model's full set (SMPL 24, SMPL-H 52, SMPL-X 55, of
        which the joints not on the tree are dropped). The offsets become the differences to
        the parents, and the pelvis is placed at ``trans + joint_positions[0]`` as the model
        places it. Default: the rest joints of :mod:`mlayer.io.smpl` (the neutral mean body,
        betas 0, as published), the pelvis likewise at ``trans`` plus its rest location.
    model : {"auto", "smpl", "smplh", "smplx"}
        The body model the poses are for. ``"auto"``: ``surface_model_type`` when the file
        has it, else by the width of ``poses`` (72 or 66: SMPL, 156: SMPL-H, 165: SMPL-X).
    return_body : bool
        Also return the file's :class:`AmassBody` (betas, gender, model), to write them back.
    max_bytes : int
        The most bytes the archive's members may expand to, all together, as their zip entries
        declare them (checked before anything is decompressed; a member cannot expand beyond
        its declared size). Default 1 GiB: an hour of SMPL-X at 120 fps is about 570 MB.

    Returns
    -------
    Motion
        SMPL (72 or 66 columns): the 22 body joints (SMPL's ``L_Hand``/``R_Hand``
        rotations, which move no joint of that tree, are dropped). SMPL-H and SMPL-X: the 52
        joints of SMPL-H (SMPL-X's jaw and eyes are dropped). Joint names are the SMPL ones
        (``Pelvis``, ``L_Hip``, ..., ``L_Index1``, ...); the joints are in depth-first order
        (``motion.skeleton.source_order[k]`` is the SMPL index of joint k). Rotations are the
        quaternions of the rotation vectors (:func:`mlayer.model.quat.exp`); ``up_axis`` is ``"z"``
        and the units metres, as AMASS's. ``betas`` and ``gender`` do not change the
        skeleton (mlayer has no body shape model); ``betas`` is checked when present.
    AmassBody
        With ``return_body``: ``(motion, body)``.

    Raises
    ------
    ParseError
        Not an ``.npz`` archive, members expanding to more than ``max_bytes``, a member that
        is not a numpy array (a raw pickle), no frames, a key that needs pickle, missing keys
        (``poses`` or ``root_orient`` + ``pose_body``, ``trans``, the frame rate), wrong
        shapes or dtypes,
        non-finite values, a frame rate not above 0; the message starts with the path.
    MlayerIOError
        The file cannot be opened.
    InvalidArgumentError
        A bad ``model`` or ``joint_positions``.
    """
    if model not in ("auto",) + MODELS:
        raise InvalidArgumentError(f"read_amass: model must be 'auto' or one of {MODELS}, got "
                                   f"{model!r}")
    if not (isinstance(max_bytes, int) and not isinstance(max_bytes, bool) and max_bytes > 0):
        raise InvalidArgumentError(f"read_amass: max_bytes must be a positive int, got "
                                   f"{max_bytes!r}")
    path = os.fspath(path)
    with _load(path) as z:
        try:
            poses, trans, fps, betas, model, gender = _arrays(z, path, max_bytes, model)
        except Error:
            raise
        except (KeyError, IndexError, TypeError, ValueError, AttributeError, SyntaxError,
                EOFError, OSError, zipfile.BadZipFile, zlib.error, tokenize.TokenError,
                NotImplementedError) as e:
            # a safety net: what the checks in _arrays missed is still a ParseError, never
            # a bare zlib.error or AttributeError (fuzz_readers.py found both)
            raise _fail(path, f"malformed archive ({type(e).__name__}: {str(e)[:200]})") from None
    F = poses.shape[0]
    if F == 0:
        raise _fail(path, "no frames: 'poses' has 0 rows")
    if trans.shape != (F, 3):
        raise _fail(path, f"'trans' must be ({F}, 3) for {F} frames of 'poses', got "
                          f"{trans.shape}")
    hands = model in _HANDS
    names, parents, default = smpl.tree(hands)
    cols = poses[:, :_BODY]
    if hands:
        lo, hi = _HANDS[model]
        cols = np.concatenate([cols, poses[:, lo:hi]], axis=1)
    offsets = _rest_offsets(joint_positions, names, parents, default, model)
    sk = Skeleton(names, parents, offsets)  # reordered to depth-first: sk.source_order
    # the rotation vectors put in the skeleton's order before exp (a third smaller than the
    # quaternions); every value was checked above and exp's output is unit, so the Motion
    # takes the arrays as they are
    vecs = np.take(cols.reshape(F, len(names), 3), sk.source_order, axis=1)
    m = Motion(sk, 1.0 / fps, trans + offsets[0], quat.exp(vecs), np.zeros((F, 0, 3)),
               _trusted=True)
    m.up_axis = "z"
    m.units = "m"
    return (m, AmassBody(betas, gender, model)) if return_body else m


def _tree_of(motion: Motion) -> tuple[tuple[str, ...], np.ndarray]:
    """The SMPL tree a motion is on (names in SMPL order) and the index of each in it."""
    sk = motion.skeleton
    names = sk.joint_names
    hands = len(names) > len(smpl.SMPL_BODY_NAMES) or any(
        n not in smpl.SMPL_BODY_NAMES for n in names)
    tree_names, tree_parents, _ = smpl.tree(hands)
    where = {n: i for i, n in enumerate(tree_names)}
    for j, n in enumerate(names):
        p = int(sk.parents[j])
        if n not in where:
            raise InvalidArgumentError(
                f"write_amass: joint {n!r} (index {j}) is not a joint of the SMPL or SMPL-H "
                f"tree (expected names such as {tree_names[:4]}...)")
        want = tree_parents[where[n]]
        want_name = tree_names[want] if want >= 0 else None
        got_name = names[p] if p >= 0 else None
        if want_name != got_name:
            raise InvalidArgumentError(
                f"write_amass: joint {n!r} (index {j}) has parent {got_name!r}; on the SMPL "
                f"tree its parent is {want_name!r}")
    if len(names) != len(tree_names):
        missing = next(n for n in tree_names if n not in names)
        raise InvalidArgumentError(
            f"write_amass: joint {missing!r} of the {'SMPL-H' if hands else 'SMPL'} tree is "
            f"missing ({len(names)} joints, the tree has {len(tree_names)})")
    index = np.array([names.index(n) for n in tree_names])
    return tree_names, index


def write_amass(motion: Motion, path: str | os.PathLike[str], *, betas: Any = None,
                gender: str | None = "neutral") -> None:
    """Write a motion on the SMPL (22) or SMPL-H (52 joints) tree as an AMASS ``.npz``.

    The inverse of :func:`read_amass`: ``poses`` (rotation vectors, :func:`mlayer.model.quat.log`,
    in SMPL order), ``trans`` (the pelvis position less its rest offset, so that reading the
    file back with the same ``joint_positions`` gives the motion again), ``mocap_framerate``,
    ``betas``, ``gender`` and ``surface_model_type``. A 22-joint motion is written as SMPL
    (72 columns, the two hand joints at rest), a 52-joint one as SMPL-H (156). The skeleton's
    offsets are not stored: AMASS files have none (the body comes from ``betas``).

    Parameters
    ----------
    motion : Motion
        On the SMPL or SMPL-H tree: the joint names of :mod:`mlayer.io.smpl` with their parents,
        in any order, and no position channels below the root.
    path : str or os.PathLike
        The output file, written as is (no ``.npz`` is appended) and atomically.
    betas : array_like, optional
        Shape coefficients to store (default: 16 zeros, the mean body).
    gender : str or None
        Stored as ``gender`` (default ``"neutral"``; None: the same).

    Raises
    ------
    InvalidArgumentError
        The motion is not on the SMPL or SMPL-H tree (the message names the first joint that
        does not match), has position channels below the root, or non-finite frames; bad
        ``betas``.
    MlayerIOError
        The file cannot be written.
    """
    if not isinstance(motion, Motion):
        raise InvalidArgumentError("write_amass: motion must be a mlayer.Motion")
    tree_names, index = _tree_of(motion)
    root_pos, rot, _ = motion._frames(finite=True)
    if motion.skeleton.trans_joints.shape[0]:
        j = int(motion.skeleton.trans_joints[0])
        raise InvalidArgumentError(
            f"write_amass: joint {motion.joint_names[j]!r} has position channels; AMASS "
            "files store rotations only below the root")
    b = np.zeros(16) if betas is None else np.asarray(betas, dtype=np.float64).reshape(-1)
    if not np.isfinite(b).all():
        raise InvalidArgumentError("write_amass: betas contains NaN or infinite values")
    F = rot.shape[0]
    poses = quat.log(np.ascontiguousarray(rot[:, index])).reshape(F, -1)
    hands = len(tree_names) > len(smpl.SMPL_BODY_NAMES)
    if not hands:
        poses = np.concatenate([poses, np.zeros((F, 6))], axis=1)
    root = int(np.flatnonzero(motion.skeleton.parents < 0)[0])
    trans = root_pos - motion.skeleton.offsets[root]
    path = os.fspath(path)
    arrays = dict(poses=poses, trans=trans, mocap_framerate=np.array(motion.fps), betas=b,
                  gender=np.array("neutral" if gender is None else str(gender)),
                  surface_model_type=np.array("smplh" if hands else "smpl"))
    try:
        with atomic_output(path, suffix=".npz") as tmp:
            with open(tmp, "wb") as f:
                np.savez(f, **arrays)
    except OSError as e:
        raise MlayerIOError(f"write_amass: cannot write {path}: {e.strerror or e}") from e
