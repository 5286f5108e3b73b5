"""What a release promises: one version everywhere, the CHOLMOD path present or refused with
one line saying how to get it, the extras and the wheel settings in pyproject.toml.
(tests/release/run.sh builds the real wheel and runs it where libcholmod cannot be found.)"""
from __future__ import annotations

import os
import re
import tomllib

import numpy as np
import pytest

import mlayer
from mlayer.layers import smoothing
from mlayer._native import lib
from conftest import REPO


def project_version() -> str:
    text = (REPO / "meson.build").read_text()
    return re.search(r"^project\([^)]*?version:\s*'([0-9]+\.[0-9]+\.[0-9]+)'", text,
                     re.S | re.M).group(1)


def test_one_version_everywhere():
    v = project_version()
    assert mlayer.__version__ == v
    assert mlayer.library_version() == v
    major, minor, patch = map(int, v.split("."))
    assert lib.mlr_version_number() == major * 10000 + minor * 100 + patch
    changelog = (REPO / "CHANGELOG.md").read_text()
    assert re.search(rf"^## \[{re.escape(v)}\]", changelog, re.M), "no CHANGELOG section"
    assert f"MLAYER_{v}" in (REPO / "docs" / "VERSIONING.md").read_text()


def test_pyproject_wheel_settings_and_extras():
    cfg = tomllib.loads((REPO / "pyproject.toml").read_text())
    assert cfg["tool"]["meson-python"]["limited-api"] is True
    assert "-Dcholmod=disabled" in cfg["tool"]["meson-python"]["args"]["setup"]
    extras = cfg["project"]["optional-dependencies"]
    assert {"plot", "batch", "test", "all"} <= set(extras)
    (combined,) = extras["all"]
    named = set(re.fullmatch(r"mlayer\[([a-z,]+)\]", combined).group(1).split(","))
    # the extras for working on mlayer (its tests, its documentation, its linters) are not features
    developer = {"test", "docs", "lint"}
    assert named == set(extras) - {"all"} - developer, "mlayer[all] must name every feature extra"
    assert cfg["project"]["license-files"] == ["LICENSE"]
    assert "mocap.cs.cmu.edu" in (REPO / "LICENSE").read_text()


def test_cholmod_solver_follows_the_build():
    y = np.sin(np.linspace(0, 3, 40))
    if mlayer.have_cholmod():
        x = mlayer.lgs(y, 2.0, solver="cholmod")
        np.testing.assert_allclose(x, mlayer.lgs(y, 2.0), rtol=0, atol=1e-10)
    else:
        with pytest.raises(mlayer.UnsupportedError, match="pip install"):
            mlayer.lgs(y, 2.0, solver="cholmod")


def test_without_cholmod_the_message_says_how_to_get_it(monkeypatch):
    # the wheels' case, whatever this build has: the check runs before any C call
    monkeypatch.setattr(smoothing, "have_cholmod", lambda: False)
    for call in (lambda: mlayer.LGS(30, solver="cholmod"),
                 lambda: mlayer.lgs(np.zeros(30), solver="cholmod")):
        with pytest.raises(mlayer.UnsupportedError) as info:
            call()
        text = str(info.value)
        assert "\n" not in text
        assert "libsuitesparse-dev" in text and "-Csetup-args=-Dcholmod=enabled" in text
        assert isinstance(info.value, NotImplementedError)
    assert mlayer.LGS(30, solver="banded").solver == "banded"


@pytest.mark.skipif(os.environ.get("MLAYER_EXPECT_CHOLMOD") != "1",
                    reason="MLAYER_EXPECT_CHOLMOD=1 (scripts/test.sh) asks for the CHOLMOD build")
def test_checkout_build_has_cholmod():
    # scripts/setup.sh builds the checkout with -Dcholmod=enabled; without it the CHOLMOD
    # tests would skip and nobody would notice
    assert mlayer.have_cholmod()
