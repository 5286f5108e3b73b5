"""The README and the Markdown pages of docs/: the quick start commands CI runs, the Python
blocks run, every relative link resolves (scripts/check_links.py)."""
import importlib.util
import re

from conftest import REPO, need

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
    """Every Python block of the README runs as written, on the bundled clip, each in a fresh
    namespace; a Python block fenced otherwise (```py, ```pycon, ```python3) would be missed
    by the pattern, so the fences' languages are checked first."""
    fences = re.findall(r"^```(\S*)\n.*?^```", README, re.M | re.S)
    assert set(fences) <= {"python", "c"}, f"fence languages {sorted(set(fences))}"
    blocks = re.findall(r"^```python\n(.*?)^```", README, re.M | re.S)
    assert len(blocks) == fences.count("python") >= 1
    monkeypatch.chdir(tmp_path)
    for code in blocks:
        exec(compile(code, "README.md", "exec"), {})
    assert (tmp_path / "walk_bold.bvh").is_file()


def test_the_interop_page_python_blocks_run(tmp_path, monkeypatch):
    """docs/interop.md says its blocks run as written on the bundled clip."""
    need("dataframe")
    page = (REPO / "docs" / "interop.md").read_text()
    blocks = re.findall(r"^```python\n(.*?)^```", page, re.M | re.S)
    assert len(blocks) == 4
    monkeypatch.chdir(tmp_path)
    for code in blocks:
        exec(compile(code, "docs/interop.md", "exec"), {})
    for name in ("walk.glb", "walk_mirrored.bvh", "track.csv", "walk_in_place.bvh"):
        assert (tmp_path / name).stat().st_size > 0, name


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


def _cli_reference():
    spec = importlib.util.spec_from_file_location("gen_cli_reference",
                                                  REPO / "docs" / "gen_cli_reference.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def test_the_cli_reference_is_generated_from_the_parser():
    """docs/cli-reference.md is what docs/gen_cli_reference.py makes of the parser now: after
    a change to an option, run `python docs/gen_cli_reference.py`."""
    gen = _cli_reference()
    assert (REPO / "docs" / "cli-reference.md").read_text() == gen.render(), \
        "docs/cli-reference.md is out of date: run python docs/gen_cli_reference.py"


def test_the_cli_reference_lists_every_command_and_option():
    from mlayer.cli._main import COMMANDS, build_parser
    gen = _cli_reference()
    page = gen.render()
    subs = gen._subcommands(build_parser())
    assert [c.name for c in COMMANDS] == list(subs)
    for name, sp in subs.items():
        assert f"\n## mlayer {name}\n" in page
        section = page.split(f"\n## mlayer {name}\n")[1].split("\n## ")[0]
        for action in sp._actions:
            for flag in action.option_strings:
                if flag not in ("-h", "--help"):
                    assert f"`{flag}" in section or f", {flag}" in section, (name, flag)
    # a default and a help text as the parser has them
    stylize = page.split("\n## mlayer stylize\n")[1].split("\n## ")[0]
    assert "| `--alpha ALPHA` | `2` |" in stylize


def test_the_cli_reference_check_fails_on_a_stale_page(tmp_path, monkeypatch):
    gen = _cli_reference()
    stale = tmp_path / "cli-reference.md"
    stale.write_text(gen.render().replace("--alpha", "--alfa"))
    monkeypatch.setattr(gen, "PAGE", stale)
    assert gen.main(["--check"]) == 1
    stale.write_text(gen.render())
    assert gen.main(["--check"]) == 0
