"""The README and the Markdown pages of docs/: the quick start commands CI runs, the Python
blocks run, every relative link resolves (scripts/check_links.py)."""
import importlib.util
import re

from conftest import REPO

README = (REPO / "README.md").read_text()


def _check_links():
    spec = importlib.util.spec_from_file_location("check_links",
                                                  REPO / "scripts" / "check_links.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_quick_start_commands_are_the_ones_ci_runs():
    quick = README[README.index("## Quick start"):README.index("## Install")]
    assert "\n    bash scripts/demo.sh\n" in quick
    assert "\n    bash scripts/test.sh\n" in quick
    assert "\nbash scripts/test.sh\n" in (REPO / ".ci" / "run").read_text()


def test_the_readme_python_blocks_run(tmp_path, monkeypatch):
    blocks = re.findall(r"^```python\n(.*?)^```", README, re.M | re.S)
    assert blocks
    monkeypatch.chdir(tmp_path)
    for code in blocks:
        exec(compile(code, "README.md", "exec"), {})
    assert (tmp_path / "walk_bold.bvh").is_file()


def test_every_link_resolves():
    assert _check_links().broken() == []


def test_a_broken_link_is_found(tmp_path):
    page = tmp_path / "page.md"
    (tmp_path / "there.md").write_text("# A heading\n")
    page.write_text("[ok](there.md) [ok](there.md#a-heading) [bad](missing.md) "
                    "[bad](there.md#nowhere) [web](https://example.org/x.md)\n")
    mod = _check_links()
    mod.ROOT = tmp_path
    assert len(mod.broken([page])) == 2
