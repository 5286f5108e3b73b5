"""Every relative link and image of README.md and docs/*.md resolves (a file, or a heading of
a Markdown file for a #fragment); `python scripts/check_links.py` prints the broken ones and
exits 1. bindings/python/tests/test_docs.py runs it."""
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parent.parent
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
FENCE = re.compile(r"^```.*?^```", re.M | re.S)


def anchors(md: pathlib.Path) -> set:
    """GitHub/MyST heading anchors of a Markdown file."""
    out = set()
    for line in FENCE.sub("", md.read_text()).splitlines():
        m = re.match(r"#+ (.*)", line)
        if m:
            a = re.sub(r"[^\w\- ]", "", m.group(1).strip().lower()).replace(" ", "-")
            out.add(a)
    return out


def broken(files=None):
    files = files or [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
    bad = []
    for f in files:
        text = FENCE.sub("", f.read_text())
        for target in LINK.findall(text):
            if re.match(r"[a-z]+:", target):  # http:, https:, mailto:
                continue
            path, _, frag = target.partition("#")
            dest = (f.parent / path).resolve() if path else f
            if not dest.exists():
                bad.append(f"{f.relative_to(ROOT)}: {target}: no such file")
            elif frag and dest.suffix == ".md" and frag not in anchors(dest):
                bad.append(f"{f.relative_to(ROOT)}: {target}: no such heading")
    return bad


if __name__ == "__main__":
    problems = broken()
    print("\n".join(problems) or "links: all resolve")
    sys.exit(1 if problems else 0)
