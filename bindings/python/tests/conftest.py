import os
import pathlib

import pytest

from mlayer import _optional

REPO = pathlib.Path(__file__).resolve().parents[3]


# ---- the optional dependencies (pyproject.toml's extras) -------------------------------------
# The suite passes with `pip install 'mlayer[test]'` alone: a test that needs a module of another
# extra says so with `requires(EXTRA, ...)` (a mark: `@requires("plot")`, or `pytestmark =
# requires("plot")` for a whole file) or `need(EXTRA, ...)` (inside a test, or in a
# pytest.param's marks), and is skipped, with the extra as its reason, where that module is
# missing. A test that checks a feature *without* its module (a MissingDependencyError) hides
# the module itself and runs everywhere (test_optional_deps.py).


def _extra_modules(extra: str) -> list[str]:
    mods = [m for m, (_, e) in _optional.EXTRAS.items() if e == extra]
    if not mods:
        raise ValueError(f"no extra {extra!r} in mlayer._optional.EXTRAS")
    return mods


def missing(*extras: str) -> str | None:
    """Why a test needing these extras cannot run here ("needs mlayer[plot]: matplotlib is not
    installed"), or None when every module of them imports."""
    for extra in extras:
        for module in _extra_modules(extra):
            if not _optional.available(module):
                return f"needs mlayer[{extra}]: {_optional.EXTRAS[module][0]} is not installed"
    return None


def requires(*extras: str) -> pytest.MarkDecorator:
    """A mark that skips the test, with the extra as the reason, unless these extras' modules
    import (e.g. ``requires("render", "video")`` for an MP4)."""
    why = missing(*extras)
    return pytest.mark.skipif(why is not None, reason=why or "")


def need(*extras: str) -> None:
    """Inside a test, or at the top of a test file (before importing the extras' modules):
    skip here, with the extra as the reason, unless these extras' modules import."""
    why = missing(*extras)
    if why is not None:
        pytest.skip(why, allow_module_level=True)


def reference(module: str, dist: str):
    """A third-party package the tests compare mlayer against (scikit-learn, MiniSom, bvhio,
    scipy: the `test` extra installs them), imported, or the test skipped saying so."""
    return pytest.importorskip(module, reason=f"needs mlayer[test]: {dist} (a reference of the "
                                              f"tests) is not installed")


#: the eight shared clips (../shared/data/mocap/README.md)
SHARED_CLIPS = ["ai4a_dog_D1_008_KAN01_002.bvh", "bandai1_walk_happy_001.bvh",
                "cmu_01_01_playground_jumps.bvh", "cmu_02_03_run_jog_25fps.bvh",
                "cmu_10_01_soccer_kick.bvh", "cmu_131_01_mj_style_walk.bvh",
                "cmu_60_10_salsa_dance.bvh", "lafan1_clip_a.bvh"]


def mocap_dir() -> pathlib.Path:
    """The shared real clips: $MLR_TEST_MOCAP_DIR, or ../shared/data/mocap beside the repo."""
    env = os.environ.get("MLR_TEST_MOCAP_DIR")
    return pathlib.Path(env) if env else REPO.parent / "shared" / "data" / "mocap"


@pytest.fixture(scope="session")
def mocap():
    d = mocap_dir()
    if not d.is_dir():
        pytest.skip(f"shared mocap clips not found at {d}")
    return d


@pytest.fixture
def rng():
    import numpy as np
    return np.random.default_rng(12345)



@pytest.fixture(scope="session")
def walk_1s(tmp_path_factory):
    """The first second (120 frames) of the bundled walk, as a BVH file."""
    import mlayer
    p = tmp_path_factory.mktemp("walk_1s") / "walk.bvh"
    mlayer.write_bvh(mlayer.data.load_sample()[:120], p)
    return p


def scale_turn(v, alpha):
    """alpha v for rotation vectors v (..., 3) and alphas (...) as the layers' synthesis scales
    them (mlr_layers.h): above |alpha| 1 an angle x past 90 degrees becomes
    90 + 72 tanh((x - 90) / 72) degrees, never below v's own angle."""
    import numpy as np
    v = np.asarray(v, float)
    a = np.broadcast_to(np.asarray(alpha, float), v.shape[:-1])
    w = a[..., None] * v
    x = np.linalg.norm(w, axis=-1)
    knee, span = 0.5 * np.pi, 0.4 * np.pi
    sat = np.maximum(np.linalg.norm(v, axis=-1), knee + span * np.tanh((x - knee) / span))
    on = (np.abs(a) > 1.0) & (x > knee)
    return np.where(on[..., None], w * (sat / np.where(on, x, 1.0))[..., None], w)

