"""mlayer: smooth motion layers and motion manifolds for character animation.

A thin numpy layer over the mlayer C library (cffi). Arrays are float64, C order, frames
along the first axis; quaternions are scalar-first (w, x, y, z).
"""
from __future__ import annotations

import logging as _logging
from types import ModuleType as _ModuleType

from . import _moved
from ._version import __version__, library_version
from .errors import (Error, InvalidArgumentError, MlayerIOError, MlayerWarning, ParseError,
                     SingularMatrixError, UnsupportedError)
from .errors import ParseWarning
from .errors import MissingDependencyError
from .model import quat
from .layers.smoothing import LGS, have_cholmod, lgs
from .model.motion import Motion, Skeleton
from .io.bvh import read_bvh, read_bvh_string, write_bvh, write_bvh_string
from .guards import metrics
from .pipeline.stream import Stream, stream_motion
from .guards import ik
from .guards.contacts import detect_contacts
from .guards.cleanup import fix_contacts
from .pipeline.retiming import (resample, slerp_resample, timewarp, timewarp_map, timewarp_speed)
from . import data
from .layers.layers import Layers, decompose, expmap_base, multires_stylize
from .layers.alpha_curve import AlphaCurve
from .pipeline.pipeline import GuardReport, Synthesis, denoise, stylize
from .model.up_axis import UpGuess, detect_up
from .model.trimming import LeadIn, lead_in, trim
from .guards.limits import JointLimits, joint_limits
from .manifold.clustering import KMeansResult, elbow, kmeans
from .manifold.som import SOM
from .manifold.features import pose_features
from .batching import batch
from .manifold.manifold import GRBF, PCA
from .manifold.mixture import GaussianMixture, fuzzy_cmeans
from .manifold.markov import Markov
from .manifold.primitives import PrimitiveModel
from .io.gltf import read_gltf, write_gltf
from .io.amass import read_amass, write_amass
from .model.mirroring import mirror, mirror_pairs
from .model.root_motion import RootTrack, apply_root_motion, extract_root_motion
from .pipeline.retarget import retarget, retarget_roles


__all__ = ["__version__", "library_version", "Error", "InvalidArgumentError", "ParseError",
           "SingularMatrixError", "MlayerIOError", "UnsupportedError", "MlayerWarning", "LGS",
           "lgs", "have_cholmod", "quat", "Motion", "Skeleton", "read_bvh", "write_bvh",
           "read_bvh_string", "write_bvh_string", "metrics", "data", "Layers", "decompose",
           "denoise", "stylize", "Synthesis", "GuardReport", "JointLimits", "joint_limits",
           "Stream", "stream_motion", "ik", "detect_contacts",
           "fix_contacts", "resample", "slerp_resample", "timewarp", "timewarp_map",
           "timewarp_speed", "kmeans", "KMeansResult", "elbow", "SOM", "pose_features", "batch",
           "PCA", "GRBF", "fuzzy_cmeans", "GaussianMixture", "Markov", "PrimitiveModel"]
__all__ += ["ParseWarning", "UpGuess", "detect_up"]
__all__ += ["LeadIn", "lead_in", "trim"]
__all__ += ["MissingDependencyError"]
__all__ += ["AlphaCurve"]
__all__ += ["read_gltf", "write_gltf"]
__all__ += ["read_amass", "write_amass"]
__all__ += ["mirror", "mirror_pairs", "RootTrack", "extract_root_motion", "apply_root_motion"]
__all__ += ["expmap_base", "multires_stylize"]
__all__ += ["retarget", "retarget_roles"]



def __getattr__(name: str) -> _ModuleType:
    """``mlayer.contacts`` and the other module paths of before the subpackages (mlayer._moved),
    with a DeprecationWarning."""
    if f"mlayer.{name}" in _moved.MOVED:
        return _moved.moved(f"mlayer.{name}")
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


_moved.install()

# the library logs (the `mlayer` logger and its children) and never prints: nothing shows
# until the application configures logging (the command line shows INFO on stderr)
_logging.getLogger("mlayer").addHandler(_logging.NullHandler())
