"""mlayer.batching.registry: the operations and their variants (no cluster needed)."""
import numpy as np
import pytest

import mlayer
from mlayer.batching import Operation, operations, parse_alphas, register_operation
from mlayer.batching.registry import variant_tag, variants


def test_the_subpackage_is_not_hidden_by_the_function():
    import mlayer.batching as b
    assert b.__name__ == "mlayer.batching" and callable(mlayer.batch)
    assert mlayer.batch is b.batch and b.run.batch is b.batch


def test_operations_table():
    ops = operations()
    assert sorted(ops) == ["denoise", "features", "resample", "stylize", "timewarp"]
    assert ops["stylize"].uses_alphas and ops["features"].extension == ".npz"
    assert variants(ops["stylize"], None) == [{"alpha": 2.0}]
    assert variants(ops["denoise"], None) == [{}]
    with pytest.raises(mlayer.InvalidArgumentError, match="stylize only"):
        variants(ops["denoise"], [1, 2])
    assert variant_tag({"alpha": 1.5}) == "_alpha1.5" and variant_tag({}) == ""
    with pytest.raises(mlayer.InvalidArgumentError, match="extension"):
        register_operation(Operation("x", lambda m, v: [], ".txt"))
    with pytest.raises(TypeError):
        register_operation("denoise")
    assert "x" not in operations()


def test_parse_alphas():
    assert parse_alphas("0.5:2.5:0.5") == [0.5, 1.0, 1.5, 2.0, 2.5]
    assert parse_alphas("0:1:0.3") == [0.0, 0.3, 0.6, 0.9]
    assert parse_alphas("1,1.5,2") == [1.0, 1.5, 2.0]
    assert parse_alphas(2) == [2.0]
    assert parse_alphas(np.arange(0.5, 1.6, 0.5)) == [0.5, 1.0, 1.5]
    for bad in ("1:0:0.5", "0:1:0", "0:1", "a:b:c", [float("nan")], "inf"):
        with pytest.raises(mlayer.InvalidArgumentError):
            parse_alphas(bad)
