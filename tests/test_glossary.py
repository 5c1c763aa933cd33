"""The README is a front door a newcomer reads in minutes, and docs/glossary.md defines its words.

- README.md stays short (:data:`MAX_README_LINES`);
- docs/glossary.md defines every term of :data:`TERMS`: a ``### term`` heading, one line of plain words under
  it, ending with a link to the page that explains it;
- every ``glossary.md#anchor`` link of the README and of docs/ names a term the glossary defines, and the
  README's first use of each term (outside code) is a link to its definition;
- the reference pages (docs/*.md, not docs/results/) that use a term link to the glossary.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
GLOSSARY = ROOT / "docs" / "glossary.md"
MAX_README_LINES = 150

# anchor of the term's heading in docs/glossary.md -> how the term is written in prose
TERMS = {
    "cpg": r"central pattern generator|\bCPGs?\b",
    "fitness": r"\bfitness",
    "pocket": r"\bpocket",
    "gamma": r"γ",
    "mu-schedule": r"μ schedule",
    "cross-over": r"\bcross-over",
    "adaptive-monte-carlo": r"adaptive Monte Carlo",
    "robust-evaluation": r"robust evaluation",
    "domain-randomisation": r"domain randomisation",
    "bristle": r"\bbristle",
    "springs-pipeline": r"springs pipeline",
    "exact-joints": r"exact joints",
    "mujoco-c": r"MuJoCo C\b",
    "here": r"\bhere\b",
    "jittered-replays": r"jittered replays",
    "carry-over": r"\bcarr(?:y|ies) over",
    "validated-champion": r"validated champion",
    "pmtg": r"\bPMTG\b",
    "mirror": r"\bmirror",
    "both-roundings": r"both roundings",
    "repertoire": r"\brepertoire",
    "qd": r"\bQD\b",
    "ite": r"IT&E",
}
# the terms a newcomer met undefined in the README (pocket, γ, bristle, PMTG, "both roundings", "here", IT&E,
# QD, the thesis's equations) and the others its findings rest on: each must have its line in the glossary
REQUIRED = ["pocket", "gamma", "mu-schedule", "robust-evaluation", "domain-randomisation", "bristle", "exact-joints",
            "pmtg", "mirror", "carry-over", "ite", "repertoire", "qd", "both-roundings", "here", "fitness",
            "jittered-replays", "validated-champion"]
LINK = re.compile(r"\[(?P<text>[^\]]*)\]\((?P<page>[^)#\s]*glossary\.md)(?:#(?P<anchor>[^)\s]+))?\)")


def anchor(heading: str) -> str:
    """GitHub's anchor of a heading (as tests/test_docs.py computes it)."""
    text = heading.lstrip("#").strip().lower()
    return re.sub(r"\s", "-", re.sub(r"[^\w\- ]", "", text))


def definitions() -> dict[str, list[str]]:
    """anchor -> the lines under its ``### `` heading, up to the next heading (blank lines dropped)."""
    out: dict[str, list[str]] = {}
    current = None
    for line in GLOSSARY.read_text().splitlines():
        if line.startswith("### "):
            current = anchor(line)
            out[current] = []
        elif line.startswith("#"):
            current = None
        elif current and line.strip():
            out[current].append(line)
    return out


def prose(text: str) -> str:
    """``text`` with its code blanked out (fenced and indented blocks, inline code, HTML comments), positions kept."""
    def blank(m: re.Match) -> str:
        return re.sub(r"[^\n]", " ", m.group(0))
    text = re.sub(r"```.*?```", blank, text, flags=re.S)
    text = re.sub(r"(?m)^(?: {4}|\t).*$", blank, text)
    text = re.sub(r"<!--.*?-->", blank, text, flags=re.S)
    return re.sub(r"`[^`\n]*`", blank, text)


def test_the_readme_is_short():
    n = len(README.read_text().splitlines())
    assert n <= MAX_README_LINES, (f"README.md has {n} lines, more than {MAX_README_LINES}: move detail to a docs page "
                                   "(docs/recipes.md, a results page) and link it")


@pytest.mark.parametrize("term", REQUIRED)
def test_the_glossary_defines_each_term_in_one_line_with_a_link(term):
    defs = definitions()
    assert term in defs, f"docs/glossary.md has no '### ' heading for {term!r}"
    lines = defs[term]
    assert len(lines) == 1, f"docs/glossary.md: {term!r} is defined in {len(lines)} lines, not one"
    assert re.search(r"\]\([^)\s]+\.md(?:#[^)\s]+)?\)\)?\.?$", lines[0]), (
        f"docs/glossary.md: the definition of {term!r} does not end with a link to the page that explains it")


def test_every_glossary_term_has_a_way_to_find_it_in_prose():
    assert set(definitions()) == set(TERMS), "TERMS (tests/test_glossary.py) and docs/glossary.md's headings differ"


def test_every_glossary_link_names_a_defined_term():
    defs = definitions()
    bad = []
    for page in [README, *sorted((ROOT / "docs").rglob("*.md"))]:
        for m in LINK.finditer(page.read_text()):
            if m["anchor"] and m["anchor"] not in defs:
                bad.append(f"{page.relative_to(ROOT)}: {m.group(0)}")
    assert not bad, "links to terms docs/glossary.md does not define:\n" + "\n".join(bad)


def test_the_readme_links_its_first_use_of_each_term_to_the_glossary():
    text = prose(README.read_text())
    links = [(m.start(), m.end(), m["anchor"]) for m in LINK.finditer(text)]
    bad = []
    for term, pattern in TERMS.items():
        first = re.search(pattern, text)
        if first is None:
            continue                                    # the README does not use it
        if not any(a <= first.start() < b and anchor_ == term for a, b, anchor_ in links):
            line = text.count("\n", 0, first.start()) + 1
            bad.append(f"README.md:{line}: {first.group(0)!r} is not linked to docs/glossary.md#{term}")
    assert not bad, "\n".join(bad)


def test_reference_pages_that_use_the_terms_link_to_the_glossary():
    bad = []
    for page in sorted((ROOT / "docs").glob("*.md")):
        if page == GLOSSARY:
            continue
        text = page.read_text()
        used = [t for t in REQUIRED if t != "here" and re.search(TERMS[t], prose(text))]
        if used and "glossary.md" not in text:
            bad.append(f"{page.relative_to(ROOT)} uses {', '.join(used)} and does not link to the glossary")
    assert not bad, "\n".join(bad)


def test_the_checks_catch_an_unlinked_first_use_and_code_is_not_prose():
    assert "pocket" not in prose("`--pocket 4`\n\n    cpgjax evolve --pocket 4\n")
    text = prose("a pocket, then [pocket](docs/glossary.md#pocket)")
    first = re.search(TERMS["pocket"], text)
    assert not any(m.start() <= first.start() < m.end() for m in LINK.finditer(text))
    assert anchor("### IT&E") == "ite" and anchor("### mu schedule") == "mu-schedule"
