"""The documentation's links lead somewhere: every relative link of README.md, CHANGELOG.md and docs/ names a file
or folder of the repository (and, with ``#anchor``, a heading of that page)."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", ROOT / "CHANGELOG.md", *sorted((ROOT / "docs").rglob("*.md"))]
LINK = re.compile(r"\]\(([^)\s]+)\)")


def anchors(page: Path) -> set[str]:
    """GitHub's anchors of a page's headings: lower case, punctuation dropped, spaces to dashes."""
    out = set()
    for line in page.read_text().splitlines():
        if line.startswith("#"):
            text = line.lstrip("#").strip().lower()
            out.add(re.sub(r"\s", "-", re.sub(r"[^\w\- ]", "", text)))
    return out


def test_every_relative_link_of_the_docs_resolves():
    bad = []
    for page in PAGES:
        for target in LINK.findall(page.read_text()):
            if re.match(r"[a-z]+:", target) or target.startswith("#"):
                continue                                   # a web address, or an anchor of the page itself
            path, _, anchor = target.partition("#")
            dest = (page.parent / path).resolve()
            if not dest.exists():
                bad.append(f"{page.relative_to(ROOT)}: {target} (no such file)")
            elif anchor and dest.suffix == ".md" and anchor not in anchors(dest):
                bad.append(f"{page.relative_to(ROOT)}: {target} (no such heading)")
    assert not bad, "\n".join(bad)


def test_the_check_catches_a_missing_file_and_a_missing_heading(tmp_path, monkeypatch):
    page = tmp_path / "p.md"
    page.write_text("# Title\n\n[a](p.md#title) [b](nowhere.md) [c](p.md#no-such) [d](https://x.org/y)\n")
    monkeypatch.setattr(__import__(__name__), "PAGES", [page])
    monkeypatch.setattr(__import__(__name__), "ROOT", tmp_path)
    try:
        test_every_relative_link_of_the_docs_resolves()
    except AssertionError as e:
        assert "nowhere.md (no such file)" in str(e) and "p.md#no-such (no such heading)" in str(e)
        assert "p.md#title" not in str(e)
    else:
        raise AssertionError("the check passed broken links")
