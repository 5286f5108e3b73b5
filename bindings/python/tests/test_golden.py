"""Golden outputs: denoise and stylize at alpha 0.5, 2 and 3 give what they gave when
data/golden.json was written (scripts/golden.py says how the outputs are reduced to
fingerprints and how to rewrite the file when a change is meant to alter them).

The clips: the bundled sample and two wild clips (always), the shared clips (when
../shared/data/mocap or $MLR_TEST_MOCAP_DIR holds them; skipped otherwise).
"""
import importlib.util
import json

import pytest

import mlayer
from conftest import REPO, mocap_dir

GOLDEN = REPO / "bindings" / "python" / "tests" / "data" / "golden.json"
#: largest change of a projection, relative to the array's largest magnitude (at least 1):
#: a change of one value by more than about 2e-12 of it fails
TOLERANCE = 1e-12


def _golden_module():
    spec = importlib.util.spec_from_file_location("golden", REPO / "scripts" / "golden.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


golden = _golden_module()
REFERENCE = json.loads(GOLDEN.read_text())


def _path(name):
    if name.startswith("shared/"):
        p = mocap_dir() / name[len("shared/"):]
        if not p.is_file():
            pytest.skip(f"shared clip not found: {p}")
        return p
    return REPO / name


def test_the_reference_covers_the_repository_clips_and_the_sample():
    assert set(golden.REPO_CLIPS) <= set(REFERENCE["clips"])
    assert REFERENCE["alphas"] == list(golden.ALPHAS)
    assert mlayer.data.sample_path().read_bytes() == (REPO / golden.REPO_CLIPS[0]).read_bytes()


@pytest.mark.parametrize("name", sorted(REFERENCE["clips"]))
def test_outputs_match_the_golden_reference(name):
    new = golden.fingerprints(mlayer, _path(name))
    bad = golden.compare_fingerprints(REFERENCE["clips"][name], new, TOLERANCE)
    assert not bad, (f"{name}: the outputs changed ({len(bad)} arrays):\n  " + "\n  ".join(bad)
                     + "\nIf the change is meant: python scripts/golden.py reference "
                     "bindings/python/tests/data/golden.json (and say why in the commit)")


def test_a_changed_value_is_caught():
    """The comparison can fail: one rotation component moved by 1e-10 is reported."""
    import numpy as np

    x = np.random.default_rng(3).standard_normal((50, 7, 4))
    ref = {"st2/rot": golden.fingerprint("st2/rot", x)}
    y = x.copy()
    y[17, 3, 2] += 1e-10 * np.sign(y[17, 3, 0])  # the hemisphere kept
    assert golden.compare_fingerprints(ref, {"st2/rot": golden.fingerprint("st2/rot", x)},
                                       TOLERANCE) == []
    assert golden.compare_fingerprints(ref, {"st2/rot": golden.fingerprint("st2/rot", y)},
                                       TOLERANCE)
    counts = {"den/rep": golden.fingerprint("den/rep", np.array([3.0, 0.0]))}
    moved = {"den/rep": golden.fingerprint("den/rep", np.array([3.0, 1.0]))}
    assert golden.compare_fingerprints(counts, moved, TOLERANCE)
