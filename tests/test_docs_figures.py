"""Each measured figure is on one results page, and wherever else it is quoted it is a link to that page with the
same value.

The rules, checked on README.md and every page under docs/ (CHANGELOG.md is history and keeps what earlier
versions measured):

- A speed ratio to MuJoCo C or MJX (``3.83× MuJoCo C``, ``10.7× / 11.6× MuJoCo C``, ``44× MJX``) lives on
  docs/results/performance.md.  Anywhere else it is the text of a link to that page, and each of its numbers is
  in the linked section.
- A carry-over count (``9 of 10 carry over``, ``carried over on 6 of 10``) lives on a results page.  Outside
  docs/results/ it is the text of a link to a results page, and its numbers are in the linked section.
- Every link into docs/results/PAGE.md[#anchor] whose text holds a number finds that number in the linked section
  (the whole page without an anchor).

And the results pages' own shape: none over 300 lines, each (the index aside) with exactly one provenance line
``*Measured:* DATE, commit HASH, …, MACHINE …``, and none speaking of "the issue".
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
MAX_LINES = 300

NUMBER = re.compile(r"\d+(?:[.,]\d+)*")
_N = r"\d[\d.,]*(?:\s*[–-]\s*\d[\d.,]*)?"                     # 3.83, 1,515, a range 10–13
RATIO = re.compile(rf"((?:{_N}\s*[×x]\s*/\s*)*{_N}\s*[×x])\**\s+(?:MuJoCo\s+C\b|MJX\b)")
CARRY = re.compile(
    r"\b\d+\s+of\s+\d+\b[^.|:;]{0,40}?\bcarr(?:y|ies|ied)\s+over\b"
    r"|\bcarr(?:y|ies|ied)\s+over\s+(?:on\s+|in\s+)?\d+\s+of\s+\d+\b"
)
LINK = re.compile(r"\[((?:[^\[\]]|\[[^\]]*\])*)\]\(([^)\s]+)\)")
PROVENANCE_LIKE = re.compile(r"\*?Measured(?::|\*)")     # "*Measured:* …", and the older "*Measured* on …"
PROVENANCE = re.compile(
    r"\*Measured:\* \d{4}-\d{2}-\d{2}(?: to \d{4}-\d{2}-\d{2})?, commit [0-9a-f]{7,40}\b.*\b(?:cores?|GPU)\b"
)


@dataclass(frozen=True)
class Kind:
    name: str
    pattern: re.Pattern
    home: str | None          # the one page it lives on, relative to the root; None: any results page
    results_exempt: bool      # results pages may quote it unlinked (each measures its own)


KINDS = (
    Kind("speed ratio", RATIO, "docs/results/performance.md", False),
    Kind("carry-over count", CARRY, None, True),
)


def numbers(text: str) -> list[str]:
    return NUMBER.findall(text.replace("**", ""))


def has_number(text: str, n: str) -> bool:
    return re.search(r"(?<![\d.,])" + re.escape(n) + r"(?![.,]?\d)", text) is not None


def slug(heading: str) -> str:
    """GitHub's anchor of a heading (as tests/test_docs.py computes it)."""
    text = heading.lstrip("#").strip().lower()
    return re.sub(r"\s", "-", re.sub(r"[^\w\- ]", "", text))


def section(page: Path, anchor: str) -> str | None:
    """The text under the heading whose anchor is ``anchor``, to the next heading of its level or above (the
    whole page for an empty anchor; None when no heading has it)."""
    lines = page.read_text().splitlines()
    if not anchor:
        return "\n".join(lines)
    fence = False
    start = level = None
    for i, line in enumerate(lines):
        if line.startswith("```"):
            fence = not fence
        if fence or not line.startswith("#"):
            continue
        depth = len(line) - len(line.lstrip("#"))
        if start is None and slug(line) == anchor:
            start, level = i, depth
        elif start is not None and depth <= level:
            return "\n".join(lines[start:i])
    return None if start is None else "\n".join(lines[start:])


def links(page: Path, text: str, root: Path):
    """(start, end, link text, target file relative to root, anchor) of every relative link into docs/results/."""
    for m in LINK.finditer(text):
        target = m.group(2)
        if re.match(r"[a-z]+:", target) or target.startswith("#"):
            continue
        path, _, anchor = target.partition("#")
        dest = (page.parent / path).resolve()
        try:
            rel = dest.relative_to(root.resolve()).as_posix()
        except ValueError:
            continue
        if rel.startswith("docs/results/") and rel.endswith(".md"):
            yield m.start(1), m.end(1), m.group(1), rel, anchor


def problems(root: Path, pages: list[Path]) -> list[str]:
    """Every quote of a figure that breaks the rules above, as ``page: quote (why)``."""
    out = []
    for page in pages:
        rel = page.relative_to(root).as_posix()
        text = page.read_text()
        found = list(links(page, text, root))
        in_results = rel.startswith("docs/results/")
        for kind in KINDS:
            if rel == kind.home or (in_results and kind.results_exempt):
                continue
            for m in kind.pattern.finditer(text):
                quote = m.group(0).replace("\n", " ")
                link = next((l for l in found if l[0] <= m.start() and m.end() <= l[1]), None)
                home_ok = link is not None and (kind.home is None or link[3] == kind.home)
                if not home_ok:
                    where = kind.home or "a results page"
                    out.append(f"{rel}: '{quote}' ({kind.name} not a link to {where})")
        for _, _, label, target, anchor in found:
            nums = numbers(label)
            if not nums:
                continue
            dest = root / target
            body = section(dest, anchor) if dest.exists() else None
            if body is None:
                continue                                    # a broken link: tests/test_docs.py says so
            for n in nums:
                if not has_number(body, n):
                    out.append(f"{rel}: '{label}' ({n} is not in {target}{'#' + anchor if anchor else ''})")
    return out


def doc_pages(root: Path) -> list[Path]:
    return sorted((root / "docs").rglob("*.md"))


def results_pages() -> list[Path]:
    return sorted((ROOT / "docs" / "results").glob("*.md"))


def test_a_figure_quoted_away_from_its_page_links_to_it_with_the_same_value():
    bad = problems(ROOT, doc_pages(ROOT))
    assert not bad, "\n".join(bad)




def test_the_readme_quotes_figures_as_links_with_the_same_value():
    bad = problems(ROOT, [ROOT / "README.md"])
    assert not bad, "\n".join(bad)


def test_every_results_page_is_at_most_300_lines():
    long = [f"{p.name}: {n}" for p in results_pages() if (n := len(p.read_text().splitlines())) > MAX_LINES]
    assert not long, long


def test_every_results_page_has_one_provenance_line():
    bad = []
    for p in results_pages():
        if p.name == "README.md":
            continue
        lines = [line for line in p.read_text().splitlines() if PROVENANCE_LIKE.match(line)]
        if len(lines) != 1 or not PROVENANCE.match(lines[0]):
            bad.append(f"{p.name}: {lines}")
    assert not bad, "\n".join(bad)


def test_no_results_page_speaks_of_the_issue():
    bad = [p.name for p in results_pages() if re.search(r"\bthe issue", p.read_text(), re.IGNORECASE)]
    assert not bad, bad


# The checker itself, on a tiny tree.

def _tree(tmp_path: Path, files: dict[str, str]) -> Path:
    for name, text in files.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    return tmp_path


HOME = "# Performance\n\n## Current speeds\n\n| springs | 256 | **3.83×** | 15.5× |\n\n## Other\n\n4.02× under load\n"
CLOSED = "# Closed loop\n\n## Fresh seeds\n\n| closed | 5 of 10 |\n"


def test_the_checker_passes_figures_linked_with_their_value(tmp_path):
    root = _tree(tmp_path, {
        "docs/results/performance.md": HOME,
        "docs/results/closed-loop.md": CLOSED,
        "docs/x.md": "Ours: [3.83× MuJoCo C and 15.5× MJX](results/performance.md#current-speeds); "
                     "[5 of 10 carry over](results/closed-loop.md#fresh-seeds).\n",
    })
    assert problems(root, doc_pages(root)) == []


def test_the_checker_catches_a_planted_mismatch(tmp_path):
    root = _tree(tmp_path, {
        "docs/results/performance.md": HOME,
        "docs/results/closed-loop.md": CLOSED,
        "docs/x.md": "[3.8× MuJoCo C](results/performance.md#current-speeds)\n",        # rounded otherwise
    })
    assert problems(root, doc_pages(root)) == [
        "docs/x.md: '3.8× MuJoCo C' (3.8 is not in docs/results/performance.md#current-speeds)"]


def test_the_checker_catches_a_value_from_another_section_and_an_unlinked_quote(tmp_path):
    root = _tree(tmp_path, {
        "docs/results/performance.md": HOME,
        "docs/results/closed-loop.md": CLOSED,
        "docs/results/steering.md": "# Steering\n\nThe engine runs 3.83× MuJoCo C.\n",
        "docs/x.md": "[4.02× MuJoCo C](results/performance.md#current-speeds), and 6 of 10 runs carry over.\n"
                     "[6 of 10 carry over](results/closed-loop.md)\n",
    })
    got = problems(root, doc_pages(root))
    assert "docs/x.md: '4.02× MuJoCo C' (4.02 is not in docs/results/performance.md#current-speeds)" in got
    assert "docs/x.md: '6 of 10 runs carry over' (carry-over count not a link to a results page)" in got
    assert "docs/x.md: '6 of 10 carry over' (6 is not in docs/results/closed-loop.md)" in got
    assert ("docs/results/steering.md: '3.83× MuJoCo C' (speed ratio not a link to docs/results/performance.md)"
            in got)
    assert len(got) == 4, got


def test_the_page_rules_catch_a_long_page_two_provenance_lines_and_the_issue(tmp_path, monkeypatch):
    root = _tree(tmp_path, {
        "docs/results/a.md": "# A\n" + "x\n" * MAX_LINES + "*Measured:* 2026-11-26, commit a94e6bc, 2 cores.\n",
        "docs/results/b.md": "# B\n\nthe issue's bar\n*Measured:* 2026-11-26, commit a94e6bc, 2 cores.\n"
                             "*Measured* on 2026-11-25.\n",
        "docs/results/c.md": "# C\n\n*Measured:* 2026-11-26, 2 cores.\n",                  # no commit
    })
    monkeypatch.setattr(__import__(__name__), "ROOT", root)
    with pytest.raises(AssertionError, match="a.md: 302"):
        test_every_results_page_is_at_most_300_lines()
    with pytest.raises(AssertionError) as e:
        test_every_results_page_has_one_provenance_line()
    assert "b.md" in str(e.value) and "c.md" in str(e.value) and "a.md" not in str(e.value)
    with pytest.raises(AssertionError, match="b.md"):
        test_no_results_page_speaks_of_the_issue()
