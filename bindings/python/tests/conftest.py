import os
import pathlib

import pytest

REPO = pathlib.Path(__file__).resolve().parents[3]


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

