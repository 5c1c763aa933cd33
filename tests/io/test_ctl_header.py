"""A `.ctl` file's header: its provenance as ``# key: value`` lines, read, written, and what a replay takes from it
(cpgjax.io.ctl_header; docs/ctl-format.md)."""

from __future__ import annotations

import glob
import os

import numpy as np
import pytest

from cpgjax.errors import CpgjaxError
from cpgjax.io.ctl import Header, format_ctl, parse_ctl, read_ctl, replay_settings
from cpgjax.sim.description import DescriptionError

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
BODY = "0.1\n0.1  0.2  0.3  0.4  0.5\n-0.1  0.0  0.0  0.0  0.0\n"
QUICK = Header(model="quadruped.wl", pipeline="exact", controller="pmtg:tilt+contact+bias:mirror", time=5.0,
               terrain="flat", run="runs/quickstart.h5",
               picked="best of generation 14 (robust score 0.186, mean of 4 perturbed episodes)")


def ctl(header: str, name: str = "x.ctl"):
    return parse_ctl(header + BODY, name)


def test_a_header_round_trips_as_comment_lines_before_the_fitness():
    h = Header(**{**QUICK.__dict__, "controller": "cpg", "lines": {}})
    text = format_ctl(np.zeros((2, 5)), 0.5, header=h)
    assert text.splitlines()[:7] == [
        "# model: quadruped.wl", "# pipeline: exact", "# controller: cpg", "# time: 5", "# terrain: flat",
        "# run: runs/quickstart.h5",
        "# picked: best of generation 14 (robust score 0.186, mean of 4 perturbed episodes)"]
    c = parse_ctl(text, "q.ctl")
    assert c.header == h and c.header.lines["time"] == 4 and c.fitness == 0.5
    assert c.header.models == ("quadruped.wl",) and c.header.pipelines == ("exact",)


def test_files_without_a_header_and_prose_comments_read_as_before():
    c = ctl("# The trot: hips -0.2 +- 0.3 sin(pi t) rad\n#   cpgjax simulate m.wl --ctl x.ctl  ->  walks\n")
    assert not c.header and c.header == Header()
    assert c.coeffs.shape == (2, 5)
    # after the fitness a comment is prose, whatever it looks like
    assert not parse_ctl("0.1\n# pipeline: rigid\n0 0 0 0 0\n").header


def test_keys_are_case_insensitive_times_may_say_s_and_lists_are_comma_separated():
    c = ctl("#Model: a.wl, models/b.wl\n# PIPELINE: Springs, exact\n# time: 2.5 s\n")
    assert c.header.models == ("a.wl", "b.wl") and c.header.pipelines == ("springs", "exact")
    assert c.header.time == 2.5
    assert ctl("# pipeline: any\n").header.pipelines == ()


@pytest.mark.parametrize("header,line,says", [
    ("# model: q.wl\n# pipeline: rigid\n", 2, "pipeline: expected springs or exact"),
    ("# time: -1\n", 1, "time: expected the episode length"),
    ("# time: soon\n", 1, "time: expected the episode length"),
    ("# terrain: lava\n", 1, "terrain:"),
    ("# run: a.h5\n# run: b.h5\n", 2, "a second 'run:' line in the header (the first is line 1)"),
    ("# picked:\n", 1, "the header's 'picked:' line has no value"),
    ("# command: -0.4\n", 1, "command: expected the commanded turning rate's range in rad/s"),
    ("# command: fast\n", 1, "command: expected the commanded turning rate's range in rad/s"),
    ("# controller: pmtg\n", 1, "its header says controller pmtg, but the file holds an open-loop CPG"),
])
def test_a_bad_header_line_is_named(header, line, says):
    with pytest.raises(DescriptionError, match=f"^x.ctl:{line}: ") as e:
        ctl(header)
    assert says in str(e.value) and "\n" not in str(e.value)


def test_a_replay_takes_the_header_pipeline_time_and_terrain_unless_told_otherwise():
    c = ctl("".join(f"{line}\n" for line in QUICK.text()).replace("pmtg:tilt+contact+bias:mirror", "cpg"))
    r = replay_settings([c], "models/quadruped.wl")
    assert (r.pipeline, r.time, r.terrain) == ("exact", 5.0, "flat")
    assert r.note == "x.ctl: pipeline exact, 5 s, terrain flat; from runs/quickstart.h5"
    r = replay_settings([c], "elsewhere/quadruped.wl", pipeline="exact", time=1.0, terrain="bump:0.02")
    assert (r.pipeline, r.time, r.terrain) == ("exact", 1.0, "bump:0.02")
    assert r.note == ("x.ctl: --time 1 instead of its 5 s, --terrain bump:0.02 instead of its flat; "
                      "from runs/quickstart.h5")
    assert replay_settings([c], "m/quadruped.wl", takes=("pipeline",)).note == "x.ctl: pipeline exact; from " \
                                                                                "runs/quickstart.h5"
    plain = parse_ctl(BODY, "old.ctl")
    assert replay_settings([plain], "models/hexapod.wl", pipeline="springs") == replay_settings([], "m.wl",
                                                                                               pipeline="springs")


def test_another_model_or_a_contradicted_pipeline_is_refused_in_one_line():
    c = ctl("# model: hexapod.wl\n# pipeline: exact\n")
    with pytest.raises(DescriptionError) as e:
        replay_settings([c], "models/quadruped.wl")
    assert str(e.value) == ("x.ctl:1: made for hexapod.wl, not quadruped.wl (its header's '# model:' line; model "
                            "files are compared by name)")
    with pytest.raises(DescriptionError) as e:
        replay_settings([c], "copies/hexapod.wl", pipeline="springs")
    assert str(e.value) == ("x.ctl:2: its header says pipeline exact; --pipeline springs contradicts it (leave "
                            "--pipeline out to use the header's)")
    assert replay_settings([c], "copies/hexapod.wl", pipeline="exact").pipeline == "exact"
    both = ctl("# pipeline: springs, exact\n")
    assert replay_settings([both], "m.wl").pipeline == "springs"
    assert replay_settings([both], "m.wl", pipeline="exact").pipeline == "exact"
    assert replay_settings([ctl("# pipeline: any\n")], "m.wl", pipeline="exact").pipeline == "exact"


def test_controllers_whose_headers_disagree_are_refused_unless_the_option_settles_it():
    a, b = ctl("# pipeline: exact\n# time: 5\n", "a.ctl"), ctl("# pipeline: springs\n# time: 10\n", "b.ctl")
    with pytest.raises(CpgjaxError, match=r"disagree on the pipeline \(a.ctl exact, b.ctl springs\): replay them "
                                          r"separately$"):
        replay_settings([a, b], "m.wl")
    with pytest.raises(CpgjaxError, match="disagree on the time .*, or give --time"):
        replay_settings([a, ctl("# pipeline: exact\n# time: 10\n", "b.ctl")], "m.wl")
    r = replay_settings([a, ctl("# pipeline: exact\n", "b.ctl")], "m.wl")
    assert (r.pipeline, r.time) == ("exact", 5.0) and r.note.startswith("a.ctl, b.ctl: pipeline exact, 5 s")


def test_a_steering_controllers_command_range_is_follows_limit_unless_given():
    """``# command: R`` (the run's ``--perturb command=R``, rad/s) is what ``follow`` takes as its ``--limit``."""
    c = ctl("# pipeline: exact\n# command: 0.4 rad/s\n")
    assert c.header.command == 0.4 and Header(command=0.4).text() == ["# command: 0.4"]
    r = replay_settings([c], "m.wl", takes=("pipeline", "command"))
    assert (r.pipeline, r.command, r.note) == ("exact", 0.4, "x.ctl: pipeline exact, --limit 0.4 rad/s (its command "
                                                             "range)")
    r = replay_settings([c], "m.wl", command=0.3, takes=("pipeline", "command"))
    assert r.command == 0.3 and r.note.endswith("--limit 0.3 instead of its command range 0.4 rad/s")
    assert replay_settings([c], "m.wl").command is None           # a command that does not take it: not said
    with pytest.raises(CpgjaxError, match="disagree on the command .*, or give --limit$"):
        replay_settings([c, ctl("# command: 0.3\n", "b.ctl")], "m.wl", takes=("command",))


def test_a_runs_header_says_its_command_range():
    from types import SimpleNamespace

    from cpgjax.io.ctl_header import run_header

    model = SimpleNamespace(episode=SimpleNamespace(time_max=10.0), terrain=SimpleNamespace(spec="flat"))
    meta = {"model_path": "models/quadruped.wl", "pipeline": "exact", "perturbations": {"command": 0.4}}
    assert run_header("r.h5", meta, model, "cpg", "x").command == 0.4
    assert run_header("r.h5", meta | {"perturbations": '{"command": 0.0}'}, model, "cpg", "x").command is None
    assert run_header("r.h5", {"model_path": "q.wl"}, model, "cpg", "x").command is None


@pytest.mark.parametrize("path", sorted(glob.glob(os.path.join(ROOT, "models", "*.ctl"))), ids=os.path.basename)
def test_every_shipped_controller_names_its_model_and_how_it_was_made(path):
    c = read_ctl(path)
    h = c.header
    assert h.models and h.pipeline and h.controller and h.picked
    assert (h.controller == "cpg") == (c.policy is None)          # the family it names is the one it holds
    assert (h.command is not None) == ("command" in h.controller)  # a steering controller says its command range
    name = os.path.basename(path)
    wl = "quadruped.wl" if name.startswith("quadruped-") else name[:-4] + ".wl"
    assert wl in h.models
    assert (h.run is None) == ("by hand" in h.picked)      # the hand-written ones come from no run
