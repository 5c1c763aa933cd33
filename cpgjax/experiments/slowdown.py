"""Table A.1 (Appendix A, `cpgjax bench --table-a1`): each thesis example's slowdown, wall seconds per simulated
second, for one robot alone and per robot in a batch, beside the thesis's (1999); compile time apart.
"""

from __future__ import annotations

import os
import time
from functools import partial

import numpy as np

# Table A.1 (Appendix A): name, model, controller, DOFs, simulated seconds and slowdown in the thesis (1999)
THESIS_A1 = (
    ("car", "car.wl", None, 4, 3.5, 1.8),
    ("worm", "worm.wl", "worm.ctl", 4, 15.0, 1.0),
    ("hexapod", "hexapod.wl", "hexapod.ctl", 12, 10.0, 8.6),
    ("quadruped", "quadruped.wl", "quadruped-trot.ctl", 8, 10.0, 9.3),
)


def _timed(f, *args):
    """(compile_s, run_s): ahead-of-time compile, then one call of the compiled program."""
    import jax

    t0 = time.perf_counter()
    c = jax.jit(f).lower(*args).compile()
    comp = time.perf_counter() - t0
    t0 = time.perf_counter()
    jax.block_until_ready(c(*args))
    return comp, time.perf_counter() - t0


def _one_robot(model, T, c):
    from cpgjax.episode.rollout import rollout

    return rollout(model, c, time=T)["fitness"]


def _batch(model, T, chunk, c):
    from cpgjax.episode.batch import evaluate

    return evaluate(model, c, time=T, chunk=chunk)["fitness"]


def table_a1(models_dir: str, *, batch: int = 256, time_s: float | None = None, chunk: int = 256,
             examples=None, progress: bool = True, pipeline: str | None = None) -> list[dict]:
    """Table A.1: each example's slowdown (wall s per simulated s) alone and per robot in a batch.

    Per example (the thesis's model, its controller, its simulated time unless ``time_s``):
    ``slowdown_one``: one robot, `episode.rollout.rollout` jitted with B = 1 on one device (no padding);
    ``slowdown_per_robot``: ``batch`` copies through `episode.batch.evaluate` (every host device,
    chunks of ``chunk``), wall time / (batch x simulated time).  Compile time is apart (ahead of time).
    ``examples``: names to run (default all four).  ``pipeline``: our simulator's (None: each model file's,
    else springs); each row names the one it ran.
    """
    import jax
    import jax.numpy as jnp
    from tqdm.auto import tqdm

    from cpgjax.episode.rollout import schedule
    from cpgjax.io.ctl import read_ctl
    from cpgjax.io.wl import load_model

    known = [e[0] for e in THESIS_A1]
    bad = [e for e in (examples or ()) if e not in known]
    if bad:
        raise ValueError(f"Table A.1 has no example {bad[0]!r} (it has {', '.join(known)})")
    todo = [e for e in THESIS_A1 if examples is None or e[0] in examples]
    rows = []
    for name, wl, ctl, dofs, t_thesis, slow in tqdm(todo, desc="Table A.1", unit="example", disable=not progress):
        model = load_model(os.path.join(models_dir, wl), pipeline=pipeline)
        T = t_thesis if time_s is None else float(time_s)
        if ctl is None:
            c = np.zeros((model.n_ctrl, model.n_coeff))
        else:
            c = read_ctl(os.path.join(models_dir, ctl), n_dof=model.n_ctrl, harmonics=model.episode.harmonics).coeffs
        inner, outer = schedule(model, T)
        sim_t = inner * outer * model.dt
        one = jnp.asarray(c, jnp.float32)[..., None]
        comp1, run1 = _timed(partial(_one_robot, model, T), one)
        many = jnp.asarray(np.repeat(np.asarray(c)[None], batch, 0), jnp.float32)
        compb, runb = _timed(partial(_batch, model, T, chunk), many)
        rows.append({"example": name, "model": wl, "controller": ctl, "dofs": int(model.nj), "thesis_dofs": dofs,
                     "dt": model.dt, "pipeline": model.pipeline, "sim_time": sim_t, "thesis_time": t_thesis,
                     "thesis_slowdown": slow,
                     "slowdown_one": run1 / sim_t, "compile_one_s": comp1, "batch": batch,
                     "slowdown_per_robot": runb / (batch * sim_t), "slowdown_batch": runb / sim_t,
                     "compile_batch_s": compb, "devices": len(jax.devices())})
    return rows
