"""The README's GIFs are what today's code draws.

README.md lists each GIF under a ``<!-- figures -->`` marker, one table row each::

    | trot | `models/quadruped.wl --ctl models/quadruped-trot.ctl --time 6 ...` | walks +0.79 m, stays up |

the arguments of the ``cpgjax render`` that drew ``docs/figures/render-NAME.gif`` and what the episode
drawn does.  The tests check that ``make figures`` draws each GIF with exactly those arguments, and replay
each controller for the same time with ``cpgjax simulate`` (the same episode the renderer records): the
distance within the tolerance of tests/replays.py, and whether the robot falls, exactly.  ``UPDATE_README=1`` rewrites
the claims from a fresh run instead (as ``make readme`` does for the examples).
"""

from __future__ import annotations

import os
import re
import shlex
from pathlib import Path

import pytest
from replays import check, replay, updated

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
MAKEFILE = ROOT / "Makefile"
ROW = re.compile(r"^\| (?P<name>[a-z]+) \| `(?P<args>[^`]+)` \| (?P<claim>[^|]+?) \|$", re.M)
FIX = "redraw it (`make figures`) and update its line (UPDATE_README=1 pytest tests/test_figures.py)"


def figures() -> list[tuple[str, str, str]]:
    text = README.read_text()
    table = text[text.index("<!-- figures -->"):]
    table = table[:table.index("\n\n")]
    return [(m["name"], m["args"], m["claim"]) for m in ROW.finditer(table)]


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
SLOW = {"car", "stairs"}   # stairs: exact joints on a course, a program of its own


@pytest.mark.parametrize("name,args,claim", [
    pytest.param(n, a, c, id=n, marks=[pytest.mark.slow] if n in SLOW else []) for n, a, c in figures()])
def test_each_gif_caption_is_what_its_controller_does_today(name, args, claim, capsys):
    dist, fell = replay(shlex.split(args), capsys)
    if os.environ.get("UPDATE_README"):
        new = updated(claim, dist, fell)
        README.write_text(README.read_text().replace(f"`{args}` | {claim} |", f"`{args}` | {new} |"))
        return
    check(claim, dist, fell, f"README.md, GIF {name!r}", FIX)


def test_the_check_fails_on_a_wrong_distance_or_fall():
    check("walks +0.79 m, stays up", 0.80, False, "x", FIX)                   # within 3 % + 0.005 m
    with pytest.raises(AssertionError):
        check("walks +0.79 m, stays up", 0.84, False, "x", FIX)
    with pytest.raises(AssertionError):
        check("walks +0.79 m, stays up", 0.79, True, "x", FIX)
    with pytest.raises(AssertionError):
        check("walks about a metre", 0.79, False, "x", FIX)


def test_the_readme_shows_the_follow_gif_that_make_figures_draws_and_its_headers_claims():
    """The README's steering example: ``make figures`` draws its GIF with the README's command, and the walks the
    README quotes are the ones the controller's header claims (tests/test_models.py replays those)."""
    text = README.read_text()
    block = text[text.index("<!-- follow -->"):]
    command = re.search(r"^    (cpgjax follow .+)$", block, re.M)[1]
    argv = shlex.split(command)
    ctl, path, video = (argv[argv.index(k) + 1] for k in ("--ctl", "--path", "--video"))
    gif = ROOT / video
    assert f"({video})" in text and gif.stat().st_size > 10_000
    make = MAKEFILE.read_text()
    assert command.replace("cpgjax ", "$(BIN)/cpgjax ", 1) in make[make.index("\nfigures:"):], (
        f"`make figures` does not draw {video} with the README's command")
    header = (ROOT / ctl).read_text()
    mujoco = re.search(rf"--path {re.escape(path)} (--engine mujoco(?: --mujoco-dt \S+)?)  ->", header, re.M)[1]
    for engine, where in (("", "Here it "), (f" {mujoco}", f"in MuJoCo C (`{mujoco}`) it ")):
        claim = re.search(rf"--path {re.escape(path)}{re.escape(engine)}  ->  (.+)$", header, re.M)[1]
        assert f"{where}{claim}" in " ".join(block.split()), f"README.md does not quote {ctl}'s claim: {claim}"
