"""mlayer.batching.inputs: finding the clips of a batch (no cluster needed; the symbolic links
are checked with a batch run in test_batch_hardening.py)."""
import pytest

import mlayer
from mlayer.batching import find_inputs


def test_find_inputs_folder_glob_files(tmp_path):
    (tmp_path / "a" / "b").mkdir(parents=True)
    for rel in ("x.bvh", "a/y.BVH", "a/b/z.bvh", "a/notes.txt", ".hidden/w.bvh"):
        p = tmp_path / rel
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text("x")
    rels = [str(r) for _, r in find_inputs(tmp_path)]
    assert rels == ["a/b/z", "a/y", "x"]
    rels = [str(r) for _, r in find_inputs(str(tmp_path / "a" / "**" / "*.bvh"))]
    assert rels == ["b/z"]  # glob is case-sensitive; paths relative to the fixed prefix "a"
    assert [str(r) for _, r in find_inputs([tmp_path / "x.bvh"])] == ["x"]
    with pytest.raises(mlayer.InvalidArgumentError):
        find_inputs(tmp_path / "missing")
