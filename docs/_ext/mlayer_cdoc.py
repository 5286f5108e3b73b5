"""Sphinx glue for the C API reference: hawkmoth reads the public headers, this module adapts them.

The headers of include/mlayer/ are written for C readers: Javadoc-style ``/** ... */`` comments
with ``@param name [in] ...`` and ``@return ...``, plain ``/* ... */`` comments on enumerators and
struct members, and prose with ``*``, ``|x|``, ``lam_c`` and hand-aligned formulas, which
reStructuredText would take for markup. Rather than change the headers, the build

1. copies them into the build tree (:func:`prepare_headers`), turning the file's opening comment
   into a section of text, the comment before an enum or struct into its documentation, and the
   trailing comment of every enumerator and member into a leading doc comment (hawkmoth only
   reads comments that precede a declaration; a member without a comment gets an empty one, so
   that every enumerator and member is listed); and ``mlr_version.h`` is made from its ``.in``;
2. turns every comment into safe reStructuredText (:func:`javadoc_to_rst`, on hawkmoth's
   ``hawkmoth-process-docstring`` event): ``@param``/``@return`` into fields, ``Allocates:`` and
   ``Threads:`` into labelled paragraphs, indented blocks (formulas, tables) into literal blocks,
   and every other character that reST would read as markup escaped.
"""
from __future__ import annotations

import re
from pathlib import Path
from typing import Any

from docutils import nodes
from docutils.parsers.rst import Directive
from sphinx import addnodes
from sphinx.util import logging

logger = logging.getLogger(__name__)

_PLAIN_OPEN = re.compile(r"^(\s*)/\*(?![*/])")
_DECL_START = re.compile(r"^\s*(typedef\b|enum\b|struct\b|MLR_API\b)")
_BODY_OPEN = re.compile(r"^\s*(typedef\s+)?(enum|struct)\b[^;]*\{\s*(/\*.*)?$")
_MEMBER = re.compile(r"^(\s*)([A-Za-z_].*?)\s*(/\*(?:\*<)?(?!\*).*)?$")
_ONE_LINE_ENUM = re.compile(r"^(\s*typedef\s+(enum|struct)\s+\w+\s*)\{(.*)\}(\s*\w+;.*)$")


def _comment_text(first: str, rest: list[str]) -> tuple[str, int]:
    """Text of a plain comment starting in ``first`` (``/* ...``), continued on ``rest``.

    Returns the text without markers and the number of lines of ``rest`` it used.
    """
    body = first[first.index("/*") + 2:]
    if body.startswith("*<"):
        body = body[2:]
    used = 0
    parts = []
    while "*/" not in body:
        parts.append(body.strip())
        if used >= len(rest):
            break
        body = rest[used]
        used += 1
    parts.append(body[:body.find("*/")].strip() if "*/" in body else body.strip())
    return " ".join(p for p in parts if p), used


def _doc_comments(text: str) -> str:
    """The header ``text`` with its comments made hawkmoth doc comments (see the module doc)."""
    lines = text.split("\n")
    out: list[str] = []
    i = 0
    if lines and lines[0].rstrip() == "/*":
        # the file's opening comment: a text section of its own ('/**/' detaches it)
        out.append("/**")
        i = 1
        while i < len(lines) and "*/" not in lines[i]:
            out.append(lines[i])
            i += 1
        if i < len(lines):
            out.append(lines[i])
            out.append("/**/")
            i += 1
    depth = 0
    while i < len(lines):
        line = lines[i]
        one = _ONE_LINE_ENUM.match(line) if depth == 0 else None
        if one:
            # typedef enum x { A = 0, B = 1 } x;  ->  one enumerator (or member) a line, each
            # listed, and the type too
            if not (out and out[-1].strip().endswith("*/")):
                out.append("/** */")
            out.append(one.group(1) + "{")
            sep = "," if one.group(2) == "enum" else ";"
            for item in (e.strip() for e in one.group(3).split(sep)):
                if item:
                    out += ["    /** */", f"    {item}{sep}"]
            out.append("}" + one.group(4))
            i += 1
            continue
        if depth == 0 and line.startswith("MLR_API") and \
                not (out and out[-1].strip().endswith("*/")):
            out.append("/** */")  # an undocumented function (a getter of a group) is listed
        if depth == 0:
            m = _PLAIN_OPEN.match(line)
            if m:
                # a comment on lines of its own: documentation if a declaration follows it
                j = i
                while j < len(lines) and "*/" not in lines[j]:
                    j += 1
                nxt = lines[j + 1] if j + 1 < len(lines) else ""
                if _DECL_START.match(nxt):
                    line = _PLAIN_OPEN.sub(r"\1/**", line, count=1)
                out.extend([line] + lines[i + 1:j + 1])
                i = j + 1
                continue
            if _BODY_OPEN.match(line):
                depth = 1
            out.append(line)
            i += 1
            continue
        # inside an enum or struct body
        stripped = line.strip()
        if stripped.startswith("}"):
            depth = 0
            out.append(line)
            i += 1
            continue
        if stripped.startswith("/*"):
            # a comment line of its own documents the member that follows it
            j = i
            while j < len(lines) and "*/" not in lines[j]:
                j += 1
            out.append(_PLAIN_OPEN.sub(r"\1/**", line, count=1))
            out.extend(lines[i + 1:j + 1])
            i = j + 1
            if i < len(lines) and _MEMBER.match(lines[i]) and "/*" in lines[i]:
                # the member after it has a comment of its own: keep the first
                code = lines[i][:lines[i].index("/*")].rstrip()
                _, used = _comment_text(lines[i], lines[i + 1:])
                out.append(code)
                i += 1 + used
            continue
        m = _MEMBER.match(line)
        if not m or not stripped:
            out.append(line)
            i += 1
            continue
        indent, code, comment = m.group(1), m.group(2), m.group(3)
        used = 0
        doc = ""
        if comment:
            doc, used = _comment_text(comment, lines[i + 1:])
        prev = out[-1].strip() if out else ""
        if not prev.endswith("*/") or comment:
            out.append(f"{indent}/** {doc} */")
        out.append(f"{indent}{code}")
        i += 1 + used
    return "\n".join(out)


def project_version(meson_build: Path) -> str:
    """The ``version:`` of the ``project()`` call in the top meson.build."""
    m = re.search(r"project\([^)]*?version\s*:\s*'([^']+)'", meson_build.read_text(), re.S)
    if not m:
        raise RuntimeError(f"no project version in {meson_build}")
    return m.group(1)


def prepare_headers(src: Path, dst: Path, version: str) -> list[str]:
    """Copy the headers of ``src`` into ``dst`` with doc comments; returns the header names."""
    dst.mkdir(parents=True, exist_ok=True)
    names = []
    for header in sorted(src.glob("*.h")):
        target = dst / header.name
        new = _doc_comments(header.read_text())
        if not target.exists() or target.read_text() != new:
            target.write_text(new)
        names.append(header.name)
    major, minor, patch = (version.split("+")[0].split("-")[0].split(".") + ["0", "0"])[:3]
    ver = (src / "mlr_version.h.in").read_text()
    for key, value in (("@MAJOR@", major), ("@MINOR@", minor), ("@PATCH@", patch),
                       ("@VERSION@", version)):
        ver = ver.replace(key, value)
    docs = {"MLR_VERSION_MAJOR": "Major version of the headers compiled against.",
            "MLR_VERSION_MINOR": "Minor version of the headers.",
            "MLR_VERSION_PATCH": "Patch version of the headers.",
            "MLR_VERSION_STRING": "The headers' version as a string literal, e.g. \"0.2.0\".",
            "MLR_VERSION_NUMBER": "major * 10000 + minor * 100 + patch: compare it with "
                                  "mlr_version_number(), the version of the loaded library."}
    out = []
    for line in ver.split("\n"):
        if line.startswith("/* Generated"):
            out += ["/** " + line[2:].strip().removesuffix("*/").strip() + " */", "/**/"]
            continue
        m = re.match(r"#define (MLR_VERSION_[A-Z]+) ", line)
        if m and m.group(1) in docs:
            out.append(f"/** {docs[m.group(1)]} */")
        out.append(line)
    ver = "\n".join(out)
    target = dst / "mlr_version.h"
    if not target.exists() or target.read_text() != ver:
        target.write_text(ver)
    return names


_ESCAPE = re.compile(r"([\\*`|_\[\]<>:])")
_FIELD = re.compile(r"^@(param|return)\s*(.*)$")
_STAR = re.compile(r"^\s*\*(?: {1,2}|$)")
_LABEL = re.compile(r"\b(Allocates|Threads):")


def _esc(text: str) -> str:
    """``text`` with every character that reST reads as inline markup escaped."""
    text = _ESCAPE.sub(r"\\\1", text)
    # a leading character could start a list, an enumeration or a directive: escape it too
    return "\\" + text if text and not text[0].isspace() and text[0] != "\\" else text


def _indent(line: str) -> int:
    return len(line) - len(line.lstrip())


def _paragraph(par: list[str]) -> list[str]:
    """One paragraph of comment text as reST lines."""
    base = min(_indent(p) for p in par)
    if par[0].lstrip().startswith("- ") and _indent(par[0]) == base:
        items: list[list[str]] = []
        for p in par:
            if p.lstrip().startswith("- ") and _indent(p) == base:
                items.append([p.lstrip()[2:]])
            else:
                items[-1].append(p.strip())
        return [f"- {_esc(' '.join(it))}" for it in items] + [""]
    if base >= 4 or any(_indent(p) > base for p in par[1:]):
        # laid out by hand (a formula, a table, an aligned list): keep it as it is
        return ["::", ""] + ["   " + p[base:] for p in par] + [""]
    text = " ".join(p.strip() for p in par)
    out = []
    # Allocates: and Threads: start paragraphs of their own, labelled
    pieces = _LABEL.split(text)
    if pieces[0].strip():
        out += [_esc(pieces[0].strip()), ""]
    for k in range(1, len(pieces), 2):
        out += [f"**{pieces[k]}:** {_esc(pieces[k + 1].strip())}".rstrip(), ""]
    return out


def javadoc_to_rst(lines: list[str]) -> list[str]:
    """reST for the lines of one header comment (markers already removed by hawkmoth)."""
    # hawkmoth strips the ' * ' of comments that open with '/**' alone on a line; comments
    # whose text starts on the '/**' line keep theirs (aligned under the text: ' *  ')
    lines = [_STAR.sub("", line) for line in lines]
    out: list[str] = []
    i = 0
    n = len(lines)
    while i < n:
        line = lines[i].rstrip()
        if not line.strip():
            i += 1
            continue
        m = _FIELD.match(line.strip())
        if m:
            own = _indent(line)
            body = [m.group(2)]
            i += 1
            while i < n and lines[i].strip() and _indent(lines[i]) > own and \
                    not _FIELD.match(lines[i].strip()):
                body.append(lines[i].strip())
                i += 1
            text = " ".join(body)
            tail = ""
            label = _LABEL.search(text)
            if label:  # "@return ... Allocates: never. Threads: any." on one line
                text, tail = text[:label.start()], text[label.start():]
            if m.group(1) == "param":
                name, _, rest = text.partition(" ")
                out.append(f":param {name}: {_esc(rest.strip())}".rstrip())
            else:
                out.append(f":returns: {_esc(text.strip())}".rstrip())
            if tail:
                out += [""] + _paragraph([tail])
            elif i >= n or not _FIELD.match(lines[i].strip()):
                out.append("")
            continue
        par = []
        while i < n and lines[i].strip() and not _FIELD.match(lines[i].strip()):
            if par and lines[i].lstrip().startswith("- ") and \
                    not par[0].lstrip().startswith("- "):
                break  # a list right after a line of text: a paragraph of its own
            par.append(lines[i].rstrip())
            i += 1
        out += _paragraph(par)
    return out


_API_DECL = re.compile(r"MLR_API\s+[^;(]*?\b(mlr_[a-z0-9_]+)\s*\(")
_DOC_BLOCK = re.compile(r"/\*\*(.*?)\*/\s*MLR_API\s+[^;(]*?\b(mlr_[a-z0-9_]+)\s*\(", re.S)
_TYPE_DECL = re.compile(r"^typedef\s+(?:struct|enum)\s+(mlr_[a-z0-9_]+)", re.M)


def header_functions(header: Path) -> list[str]:
    """Names of the functions a public header exports (its MLR_API declarations)."""
    return _API_DECL.findall(header.read_text())


def header_types(header: Path) -> list[str]:
    """Names of the structs and enums a public header typedefs."""
    return _TYPE_DECL.findall(header.read_text())


def _clause(doc: str, label: str) -> str:
    """The text after ``label:`` in a doc comment, up to the next label or the end."""
    text = " ".join(line.strip().lstrip("*").strip() for line in doc.split("\n"))
    m = re.search(label + r":\s*(.*?)(?=\s*\b(?:Allocates|Threads|Cost|@return|@param)\b|$)", text)
    return m.group(1).strip() if m else ""


def threads_rows(include: Path) -> list[tuple[str, str, str, str]]:
    """(header, function, Allocates, Threads) for every documented function of the headers."""
    rows = []
    for header in sorted(include.glob("*.h")):
        documented = {}
        for doc, name in _DOC_BLOCK.findall(header.read_text()):
            doc = doc.split("/**")[-1]
            documented[name] = (_clause(doc, "Allocates"), _clause(doc, "Threads"))
        for name in header_functions(header):
            # a getter listed under its group's comment has no lines of its own
            alloc, threads = documented.get(name, ("", ""))
            rows.append((header.name, name, alloc, threads))
    return rows


class ThreadsTable(Directive):
    """``.. mlayer-threads-table::``: every function's Allocates and Threads lines, from the
    headers themselves, so the table cannot drift from them."""

    has_content = False

    def run(self) -> list[nodes.Node]:
        env = self.state.document.settings.env
        include = Path(env.config.mlayer_include_dir)
        rows = threads_rows(include)
        for header in sorted(include.glob("*.h")):
            env.note_dependency(str(header))
        table = nodes.table(classes=["mlayer-threads"])
        group = nodes.tgroup(cols=3)
        table += group
        for width in (30, 25, 45):
            group += nodes.colspec(colwidth=width)
        head = nodes.thead()
        group += head
        body = nodes.tbody()
        group += body

        def row(cells: list[nodes.Node]) -> nodes.row:
            r = nodes.row()
            for cell in cells:
                entry = nodes.entry()
                entry += cell
                r += entry
            return r

        head += row([nodes.paragraph(text=t) for t in ("function", "Allocates", "Threads")])
        for _, name, alloc, threads in rows:
            ref = addnodes.pending_xref("", refdomain="c", reftype="func", reftarget=name,
                                        refexplicit=False, refwarn=True)
            ref += nodes.literal(text=name + "()")
            para = nodes.paragraph()
            para += ref
            body += row([para, nodes.paragraph(text=alloc or "(no line)"),
                         nodes.paragraph(text=threads or "(no line: the general rule)")])
        return [table]


def _check_complete(app: Any, env: Any) -> None:
    """Every exported function and every struct/enum typedef of the headers is documented, and
    every name of ``mlayer.__all__``."""
    include = Path(app.config.mlayer_include_dir)
    objects = {name for name, *_ in env.get_domain("c").get_objects()}
    missing = []
    for header in sorted(include.glob("*.h")):
        for name in header_functions(header) + header_types(header):
            if name not in objects:
                missing.append(f"{header.name}: {name}")
    if missing:
        logger.warning("C API reference: not documented: %s", ", ".join(missing))
    py = {name for name, *_ in env.get_domain("py").get_objects()}
    import mlayer
    # a module of __all__ (mlayer.quat) is documented under the path of its file
    # (mlayer.model.quat, docs/ARCHITECTURE.md "The Python package")
    absent = [n for n in mlayer.__all__ if n != "__version__" and f"mlayer.{n}" not in py
              and getattr(getattr(mlayer, n), "__name__", None) not in py]
    if absent:
        logger.warning("Python API reference: not documented: %s", ", ".join(absent))


def _process(app: Any, lines: list[str], transform: str | None, options: dict) -> None:
    lines[:] = javadoc_to_rst(lines)


def setup(app: Any) -> dict:
    """Register the comment conversion (the headers are prepared by conf.py)."""
    app.add_config_value("mlayer_include_dir", "", "env")
    app.add_directive("mlayer-threads-table", ThreadsTable)
    app.connect("hawkmoth-process-docstring", _process)
    app.connect("env-check-consistency", _check_complete)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
