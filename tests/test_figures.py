"""The README's GIFs are what today's code draws.

README.md lists each GIF under a ``<!-- figures -->`` marker, one table row each::

    | trot | `models/quadruped.wl --ctl models/quadruped-trot.ctl --time 6 ...` | walks +0.79 m, stays up |

the arguments of the ``cpgjax render`` that drew ``docs/figures/render-NAME.gif`` and what the episode
drawn does.  The tests check that ``make figures`` draws each GIF with exactly those arguments, and replay
each controller for the same time with ``cpgjax simulate`` (the same episode the renderer records): the
distance within the tolerance below, and whether the robot falls, exactly.  ``UPDATE_README=1`` rewrites
the claims from a fresh run instead (as ``make readme`` does for the examples).
"""

from __future__ import annotations

import os
import re
import shlex
from pathlib import Path

import pytest

from cpgjax import cli

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
MAKEFILE = ROOT / "Makefile"
# The claim's distance is written with two decimals (half a unit: 0.005 m) and varies across CPUs by the
# spread tests/test_readme.py measured on the trot (1.4 %, its tolerance 3 %): both together.
RTOL, ATOL = 0.03, 0.005
ROW = re.compile(r"^\| (?P<name>[a-z]+) \| `(?P<args>[^`]+)` \| (?P<claim>[^|]+?) \|$", re.M)
CLAIM = re.compile(r"(?P<verb>[a-z]+) (?P<dist>[-+]\d+\.\d\d) m(?P<what>[^,]*), (?P<fall>stays up|falls)$")


def figures() -> list[tuple[str, str, str]]:
    text = README.read_text()
    table = text[text.index("<!-- figures -->"):]
    table = table[:table.index("\n\n")]
    return [(m["name"], m["args"], m["claim"]) for m in ROW.finditer(table)]


def replay(args: str, capsys) -> tuple[float, bool]:
    """Distance and fall of the episode `cpgjax render ARGS` draws, replayed by `cpgjax simulate`."""
    argv = shlex.split(args)
    keep, i = [], 0
    while i < len(argv):                       # simulate takes the model, --ctl, --time, --terrain, --pipeline
        if argv[i] in ("--camera", "--fps", "--size", "--out", "--engine"):
            i += 2
            continue
        keep.append(argv[i])
        i += 1
    capsys.readouterr()
    assert cli.main(["simulate", *keep]) == 0
    out = capsys.readouterr().out
    dist = float(re.search(r"^distance\s+([-+]\d+\.\d+) m", out, re.M).group(1))
    fell = re.search(r"^fallen\s+(yes|no)", out, re.M).group(1) == "yes"
    return dist, fell


def check(claim: str, dist: float, fell: bool, name: str) -> None:
    m = CLAIM.match(claim)
    assert m, f"README.md: the claim of GIF {name!r} should read 'VERB +D.DD m[ …], stays up|falls': {claim!r}"
    want = float(m["dist"])
    assert abs(dist - want) <= RTOL * abs(want) + ATOL, (
        f"GIF {name!r}: the controller now goes {dist:+.3f} m, README.md says {want:+.2f} m: redraw it "
        "(`make figures`) and update its line (UPDATE_README=1 pytest tests/test_figures.py)")
    now = "falls" if fell else "stays up"
    assert now == m["fall"], f"GIF {name!r}: README.md says it {m['fall']}, it now {now}"


def test_the_readme_lists_its_gifs_and_each_exists():
    rows = figures()
    assert len(rows) >= 3
    text = README.read_text()
    for name, _, _ in rows:
        gif = ROOT / "docs" / "figures" / f"render-{name}.gif"
        assert gif.stat().st_size > 10_000, gif
        assert f"(docs/figures/render-{name}.gif)" in text, f"README.md does not show {gif.name}"


def test_make_figures_draws_each_gif_with_the_readme_arguments():
    make = MAKEFILE.read_text()
    target = make[make.index("\nfigures:"):]
    target = target[:target.find("\n\n") if "\n\n" in target else None]
    for name, args, _ in figures():
        line = f"render {args} --out docs/figures/render-{name}.gif"
        assert line in target, f"`make figures` does not draw render-{name}.gif as README.md says: {line}"


# The car (136 contact points on a ramp at a 0.1 ms step) costs as much as the others together: slow.
SLOW = {"car"}


@pytest.mark.parametrize("name,args,claim", [
    pytest.param(n, a, c, id=n, marks=[pytest.mark.slow] if n in SLOW else []) for n, a, c in figures()])
def test_each_gif_caption_is_what_its_controller_does_today(name, args, claim, capsys):
    dist, fell = replay(args, capsys)
    if os.environ.get("UPDATE_README"):
        m = CLAIM.match(claim)
        new = f"{m['verb']} {dist:+.2f} m{m['what']}, {'falls' if fell else 'stays up'}"
        README.write_text(README.read_text().replace(f"`{args}` | {claim} |", f"`{args}` | {new} |"))
        return
    check(claim, dist, fell, name)


def test_the_check_fails_on_a_wrong_distance_or_fall():
    check("walks +0.79 m, stays up", 0.80, False, "x")                   # within 3 % + 0.005 m
    with pytest.raises(AssertionError):
        check("walks +0.79 m, stays up", 0.84, False, "x")
    with pytest.raises(AssertionError):
        check("walks +0.79 m, stays up", 0.79, True, "x")
    with pytest.raises(AssertionError):
        check("walks about a metre", 0.79, False, "x")
