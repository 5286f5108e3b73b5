"""Integer arguments mean one thing everywhere (mlayer._args.integer): a Python or NumPy
integer, never a bool or a float, within the argument's bounds."""
import numpy as np
import pytest

import mlayer
from mlayer._args import integer, threads
from mlayer.errors import InvalidArgumentError


def test_integer_accepts_python_and_numpy_integers():
    assert integer(3, "k", 1) == 3
    assert type(integer(np.int64(3), "k", 1)) is int
    assert integer(np.uint8(0), "seed", 0) == 0
    assert integer(-5, "offset") == -5


@pytest.mark.parametrize("bad", [3.0, np.float64(3.0), True, np.bool_(True), "3", None, 2.5])
def test_integer_refuses_what_is_not_an_integer(bad):
    with pytest.raises(InvalidArgumentError, match=r"^k must be an integer >= 1, got "):
        integer(bad, "k", 1)


def test_integer_names_the_bounds():
    with pytest.raises(InvalidArgumentError, match=r"order must be an integer in 1 \.\. 2, got 3"):
        integer(3, "order", 1, 2)
    with pytest.raises(InvalidArgumentError, match=r"lag must be an integer <= 9, got 10"):
        integer(10, "lag", hi=9)
    assert threads(None) == 0 and threads(2) == 2
    with pytest.raises(InvalidArgumentError, match="threads must be an integer >= 1"):
        threads(0)


def test_counts_have_one_meaning_across_the_package():
    """kmeans(X, 3.0) and fuzzy_cmeans(X, 3.0) answer alike (before, the first worked)."""
    X = np.random.default_rng(0).normal(size=(40, 2))
    calls = [lambda k: mlayer.kmeans(X, k), lambda k: mlayer.fuzzy_cmeans(X, k),
             lambda k: mlayer.GaussianMixture(k), lambda k: mlayer.PCA(k),
             lambda k: mlayer.SOM(k, 2, 2), lambda k: mlayer.elbow(X, [1, k])]
    for call in calls:
        with pytest.raises(InvalidArgumentError, match="must be an integer"):
            call(3.0)
        call(np.int32(2))
