"""mlayer: smooth motion layers and motion manifolds for character animation.

A thin numpy layer over the mlayer C library (cffi). Arrays are float64, C order, frames
along the first axis; quaternions are scalar-first (w, x, y, z).
"""
from __future__ import annotations

import logging as _logging

from ._version import __version__, library_version
from .errors import (Error, InvalidArgumentError, MlayerIOError, MlayerWarning, ParseError,
                     SingularMatrixError, UnsupportedError)
from .errors import ParseWarning
from .errors import MissingDependencyError
from . import quat
from .smoothing import LGS, have_cholmod, lgs
from .motion import Motion, Skeleton
from .bvh import read_bvh, read_bvh_string, write_bvh, write_bvh_string
from . import metrics
from .stream import Stream, stream_motion
from . import ik
from .contacts import detect_contacts
from .cleanup import fix_contacts
from .retiming import (resample, slerp_resample, timewarp, timewarp_map, timewarp_speed)
from . import data
from .layers import Layers, decompose, expmap_base, multires_stylize
from .alpha_curve import AlphaCurve
from .pipeline import GuardReport, Synthesis, denoise, stylize
from .up_axis import UpGuess, detect_up
from .trimming import LeadIn, lead_in, trim
from .limits import JointLimits, joint_limits
from .clustering import KMeansResult, elbow, kmeans
from .som import SOM
from .features import pose_features
from .batching import batch
from .manifold import GRBF, PCA
from .mixture import GaussianMixture, fuzzy_cmeans
from .markov import Markov
from .primitives import PrimitiveModel
from .gltf import read_gltf, write_gltf
from .amass import read_amass, write_amass
from .mirror import mirror, mirror_pairs
from .root_motion import RootTrack, apply_root_motion, extract_root_motion
from .retarget import retarget, retarget_roles


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

# the library logs (the `mlayer` logger and its children) and never prints: nothing shows
# until the application configures logging (the command line shows INFO on stderr)
_logging.getLogger("mlayer").addHandler(_logging.NullHandler())
