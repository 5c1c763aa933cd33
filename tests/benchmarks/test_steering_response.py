"""A smoke run of ``benchmarks/steering_response.py`` (the tables of docs/results/steering.md): two steering
controllers, each under the nine commands in one batch, and the table of turning rates.  The episode program is
stood in for by a walk that turns at the commanded rate (the real one, a steered exact-joint program, compiles for
about 13 s on 2 cores; `cpgjax follow --ctl` and tests/episode/test_steering.py run it): the batch it is given,
the turning rates measured from the body's quaternions and the table are the script's own."""

from __future__ import annotations

import numpy as np
import pytest
from benchcases import load_benchmark


@pytest.fixture(scope="module")
def bench():
    return load_benchmark("steering_response")


def _steering_ctl(path) -> str:
    """A closed loop on the trot's CPG that reads the command (its policy of zeros)."""
    from cpgjax.episode import policy as pol
    from cpgjax.io.ctl import PolicyTable, read_ctl, write_ctl
    from cpgjax.io.wl import load_model

    m = load_model("models/quadruped.wl")
    fam = pol.parse_controller("pmtg:tilt+contact+command+steer+bias")
    coeffs = read_ctl("models/quadruped-trot.ctl", n_dof=8, harmonics=2).coeffs
    c = pol.ClosedLoop(fam, coeffs, np.zeros((fam.n_out(m), fam.n_in(m)), np.float32), np.zeros((), np.float32))
    write_ctl(path, coeffs, policy=PolicyTable(**pol.table_fields(c, m)), exact=True)
    return str(path)


def test_each_controller_under_each_command_and_its_table(bench, tmp_path, monkeypatch, capsys):
    import cpgjax.episode.batch

    ctls = [_steering_ctl(tmp_path / "a.ctl"), _steering_ctl(tmp_path / "b.ctl")]
    n, T = len(bench.COMMANDS), 0.3
    seen = {}

    def walk(model, c, *, time, record):
        """The tracked body turning at the commanded rate, as fast as the command is large; the last robot falls."""
        seen.update(steer=c.steer, width=c.coeffs.shape[0], time=time, record=record)
        t = np.linspace(0.0, time, 7)
        psi = t[:, None] * np.asarray(c.steer.first)[None]                    # [samples, robots]
        q = np.zeros((len(t), 4, len(model.body_names), 2 * n))
        q[:, 0, model.track], q[:, 3, model.track] = np.cos(psi / 2), np.sin(psi / 2)
        return {"traj": {"q": q}, "speed": np.abs(np.asarray(c.steer.first)),
                "fallen": np.arange(2 * n) == 2 * n - 1}

    monkeypatch.setattr(cpgjax.episode.batch, "simulate", walk)
    assert bench.main([*ctls, "--time", str(T)]) == 0
    cmd = np.tile(bench.COMMANDS, 2)
    np.testing.assert_array_equal(seen["steer"].first, cmd)
    np.testing.assert_array_equal(seen["steer"].second, cmd)
    assert (seen["steer"].switch, seen["steer"].limit, seen["width"], seen["time"], seen["record"]) == (
        T / 2, pytest.approx(0.4), 2 * n, T, True)
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "| controller | -0.4 | -0.3 | -0.2 | -0.1 | +0.0 | +0.1 | +0.2 | +0.3 | +0.4 |"
    assert len(lines) == 4 and lines[2].startswith(f"| {ctls[0]} | -0.40, 0.40 | -0.30, 0.30 | ")
    assert lines[3].endswith(" | +0.30, 0.30 | +0.40, 0.40 (fell) |")


def test_a_turn_past_half_a_circle_is_unwrapped(bench):
    t = np.linspace(0.0, 10.0, 201)
    psi = np.stack([1.0 * t, -0.7 * t], 1)                                   # 10 rad and -7 rad in 10 s
    q = np.stack([np.cos(psi / 2), 0 * psi, 0 * psi, np.sin(psi / 2)])
    np.testing.assert_allclose(bench.turning_rates(q, 10.0), [1.0, -0.7], atol=1e-9)


def test_mujoco_walks_each_controller_under_each_constant_command_and_adds_its_rows(bench, tmp_path, monkeypatch,
                                                                                     capsys):
    """``--engine mujoco``: the batch's commands reach MuJoCo C as each controller's constant command (no schedule),
    a real 0.1 s walk from rest, its rows measured from the root body's quaternions as ours are."""
    import cpgjax.crosscheck.engines as engines

    ctls = [_steering_ctl(tmp_path / "a.ctl"), _steering_ctl(tmp_path / "b.ctl")]
    real, seen = engines.mujoco_closed_run, {}

    def run(model, c, **kw):
        seen.update(command=np.asarray(c.command), steer=c.steer, time=kw["time"], dt=kw["timestep"])
        out = real(model, c, **kw)
        seen["qpos"] = out[1]
        return out

    monkeypatch.setattr(engines, "mujoco_closed_run", run)
    assert bench.main([*ctls, "--time", "0.1", "--engine", "mujoco", "--mujoco-dt", "0.002"]) == 0
    np.testing.assert_array_equal(seen["command"], np.tile(bench.COMMANDS, 2))
    assert seen["steer"] is None and (seen["time"], seen["dt"]) == (0.1, 0.002)
    lines = capsys.readouterr().out.splitlines()
    assert lines[0].startswith("| controller | engine | -0.4 |") and len(lines) == 4
    assert all(" | MuJoCo C, 2 ms | " in row for row in lines[2:])
    q = np.moveaxis(seen["qpos"][:, :, 3:7], 2, 0)                       # the root's quaternion, [4, robots, samples]
    turn = bench.turning_rates(np.moveaxis(q, 1, 2), 0.1)[:9]
    assert [c.split(",")[0] for c in lines[2].strip(" |").split(" | ")[2:]] == [f"{t:+.2f}" for t in turn]


def test_inputs_table_shows_the_mean_tilt_and_contact_each_engine_read(bench, tmp_path, monkeypatch, capsys):
    """``--inputs``: per controller, engine and command of SHOWN, the episode's mean of each tilt and contact
    input, after the t = 0 sample: ours from the recorded observations (stood in for: input k of robot j reads
    j + k / 100 at every sample but the first), MuJoCo C's from a real 0.1 s walk's observations."""
    import cpgjax.crosscheck.engines as engines
    import cpgjax.episode.batch

    ctls = [_steering_ctl(tmp_path / "a.ctl"), _steering_ctl(tmp_path / "b.ctl")]
    n = len(bench.COMMANDS)

    def walk(model, c, *, time, record):
        q = np.zeros((7, 4, len(model.body_names), 2 * n))
        q[:, 0] = 1.0
        obs = np.arange(2 * n)[None, None] + np.arange(10)[None, :, None] / 100 + np.zeros((7, 1, 1))
        obs[0] = 99.0                                                       # t = 0: left out of the mean
        return {"traj": {"q": q, "obs": obs}, "speed": np.zeros(2 * n), "fallen": np.zeros(2 * n, bool)}

    real, seen = engines.mujoco_closed_run, {}

    def run(model, c, **kw):
        out = real(model, c, **kw)
        seen["obs"] = out[3]
        return out

    monkeypatch.setattr(cpgjax.episode.batch, "simulate", walk)
    monkeypatch.setattr(engines, "mujoco_closed_run", run)
    assert bench.main([*ctls, "--time", "0.1", "--engine", "both", "--inputs"]) == 0
    lines = capsys.readouterr().out.splitlines()
    k = lines.index("")
    assert lines[k + 1] == ("| controller | engine | command | roll | pitch | contact AR | contact AL | contact PR | "
                            "contact PL |")
    rows = [r.strip(" |").split(" | ") for r in lines[k + 3:]]
    assert [(r[0], r[1], r[2]) for r in rows] == [(c, e, s) for c in ctls for e in ("ours", "MuJoCo C, 2 ms")
                                                  for s in ("-0.4", "+0.0", "+0.4")]
    assert rows[1][3:] == [f"{4 + i / 100:+.3f}" for i in range(6)]        # ours: robot 4 (command 0), inputs 0-5
    mean = seen["obs"].mean(1)                                              # MuJoCo C: [robots, inputs]
    assert rows[11][3:] == [f"{mean[n + 8, i]:+.3f}" for i in range(6)]    # controller b, +0.4: robot n + 8
