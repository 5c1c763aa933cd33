"""A smoke run of ``benchmarks/climb.py`` (docs/results/stairs.md): two runs at two rises, the table, the shares
and the figure.  The replays in both engines are stood in for (``transfer.replay_runs`` is tested in
tests/crosscheck/test_transfer.py, the grounds in tests/crosscheck/test_ground_ledges.py): for real, each rise is a
program of its own."""

from __future__ import annotations

import json

from benchcases import load_benchmark


def test_a_run_climbs_where_at_most_one_replay_fails(tmp_path, monkeypatch, capsys):
    from cpgjax.crosscheck import transfer
    from cpgjax.sim.terrain import make_terrain

    bench = load_benchmark("climb")
    assert make_terrain(bench.course_of(0.04)).ledges.levels.max() == 0.2
    seen = []

    def replay_runs(paths, *, terrain, **kw):
        seen.append(terrain)
        rise = float(terrain.split(",")[1].split(":")[1])
        out = []
        for k, p in enumerate(paths):
            fails = 0 if rise < 0.03 or k == 0 else 5
            one = {"fitness": 0.2, "speed": 0.2, "distance": 4.0, "fallen": False}
            jit = {"mean": 0.2, "sd": 0.0, "falls": fails, "speed": 0.2, "short": 1}
            out.append(transfer.Replay(run=p, evaluation="robust", cell="c", seed=k, fitness_in_run=0.2, ours=one,
                                       mujoco=one, ours_jit=dict(jit, falls=0), mujoco_jit=jit))
        return out

    monkeypatch.setattr(transfer, "replay_runs", replay_runs)
    assert bench.main(["a.h5", "b.h5", "--rises", "0.02,0.04", "--replays", "8", "--out", str(tmp_path)]) == 0
    assert seen == [bench.course_of(0.02), bench.course_of(0.04)]
    out = capsys.readouterr().out
    assert "| 2 | 2 | 2 | 2 | 2 |" in out and "| 4 | 2 | 2 | 1 | 1 |" in out
    rows = json.loads((tmp_path / "climb.json").read_text())["rows"]
    assert [r["mujoco"]["climbs"] for r in rows] == [True, True, True, False]     # one short replay is allowed
    assert (tmp_path / "climb.png").stat().st_size > 1000
    assert bench.main(["a.h5", "--rises", "x"]) == 2
