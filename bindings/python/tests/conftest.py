import os
import pathlib

import pytest

REPO = pathlib.Path(__file__).resolve().parents[3]


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
