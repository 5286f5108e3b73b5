"""Autodoc glue for the docstrings of the mlayer package written before the numpy style.

Many docstrings describe their arguments as a hand-aligned table::

    alpha       scale of the controllable layer ...
                (1: denoised, > 1 exaggerated)

which reStructuredText reads as definition lists and block quotes that end without a blank
line, and ``|x|`` (a norm) as a substitution reference. Until every public docstring is in the
numpy style (Parameters / Returns / Raises sections, which napoleon renders), this hook, run
before napoleon, keeps such docstrings as their authors laid them out:

- in a docstring without any numpy section, a paragraph laid out by hand (a line indented
  more than the paragraph's first line, or an indented first line) becomes a literal block;
- everywhere outside ````literals````, a ``|`` is escaped, so ``|alpha| > 1`` stays text.

Numpy-style docstrings are otherwise passed to napoleon unchanged.
"""
from __future__ import annotations

import re
from typing import Any

_SECTION_RULE = re.compile(r"^\s*-{3,}\s*$")
_LITERAL = re.compile(r"(``.*?``)")


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip())


def _escape_bars(line: str) -> str:
    """``line`` with ``|`` escaped outside double-backtick literals."""
    parts = _LITERAL.split(line)
    return "".join(p if i % 2 else p.replace("|", r"\|") for i, p in enumerate(parts))


def legacy_to_rst(lines: list[str]) -> list[str]:
    """reST for a docstring's lines (as autodoc gives them: common indentation removed)."""
    numpy_style = any(_SECTION_RULE.match(line) for line in lines)
    out: list[str] = []
    par: list[str] = []

    def flush() -> None:
        if not par:
            return
        base = min(_indent(p) for p in par)
        by_hand = _indent(par[0]) > 0 or any(_indent(p) > base for p in par[1:])
        if by_hand and not numpy_style:
            if out and out[-1].strip():
                out.append("")
            out.extend(["::", ""] + ["    " + p[base:] for p in par] + [""])
        else:
            out.extend(_escape_bars(p) for p in par)
            out.append("")
        par.clear()

    in_literal = False
    for line in lines:
        if in_literal:
            # an explicit literal block (after '::') stays as it is, up to its end
            if line.strip() and _indent(line) == 0:
                in_literal = False
            else:
                out.append(line)
                continue
        if not line.strip():
            flush()
            continue
        par.append(line)
        if line.rstrip().endswith("::"):
            flush()
            in_literal = True
    flush()
    while out and not out[-1].strip():
        out.pop()
    return out


def _process(app: Any, what: str, name: str, obj: Any, options: Any, lines: list[str]) -> None:
    lines[:] = legacy_to_rst(lines)


def _end_field_lists(app: Any, what: str, name: str, obj: Any, options: Any,
                     lines: list[str]) -> None:
    """After napoleon: text that follows its last field with no blank line (a closing
    paragraph after the Parameters section) gets one, so the field list ends cleanly."""
    k = 1
    while k < len(lines):
        prev, line = lines[k - 1], lines[k]
        if line.strip() and not line[0].isspace() and not line.startswith(":") and \
                prev.strip() and (prev.startswith(":") or prev[0].isspace()) and \
                any(p.startswith(":") for p in lines[max(0, k - 40):k]):
            lines.insert(k, "")
            k += 1
        k += 1


def setup(app: Any) -> dict:
    """Register the hook ahead of napoleon (priority 400 < napoleon's 500)."""
    app.connect("autodoc-process-docstring", _process, priority=400)
    app.connect("autodoc-process-docstring", _end_field_lists, priority=600)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
