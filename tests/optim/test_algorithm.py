"""The optimisers' contract (cpgjax.optim.algorithm): an algorithm written against it alone runs in the shared
generation step beside the GA, in one program; it reads the problem's outputs by name; a run file stores its
state by name and refuses to resume from another layout."""

from __future__ import annotations

import dataclasses

import h5py
import jax
import jax.numpy as jnp
import numpy as np
import pytest

from cpgjax.errors import ResultsError
from cpgjax.experiments.evolve import run_ga
from cpgjax.experiments.runner import run_keys
from cpgjax.optim.algorithm import Algorithm, make_algorithm, make_chunk_fn, stack_params
from cpgjax.optim.analytic import analytic_problem
from cpgjax.optim.ga import GAConfig

G = 10
# the cached analytic problem and the GA settings of tests/optim/test_ga.py: `cpgjax evolve`'s program for them is
# compiled once for both files (in one process, or through the suite's compilation cache); the problem's output
# besides fitness and diverged, "distance", reaches the algorithms by name
PROBLEM = analytic_problem("analytic:sphere:10")
GA = GAConfig(generations=25, crossover=True, pocket=5, seed=7, chunk=6, gamma=0.1)


@jax.tree_util.register_dataclass
@dataclasses.dataclass(frozen=True)
class ClimbState:
    best: jax.Array           # [G]
    best_fitness: jax.Array   # []
    asked: jax.Array          # [N, G]: what ask gave (ask may change the state; tell gets the state it left)
    distance: jax.Array       # [N]: the problem's output "distance" of the genomes told last


@dataclasses.dataclass(frozen=True, kw_only=True, eq=False)
class HillClimber(Algorithm[ClimbState]):
    """A toy written against the contract alone: Gaussian steps around the best genome so far, of a per-run
    traced size (``params``)."""

    def init(self, params, key):
        return ClimbState(jnp.zeros(G), jnp.float32(-jnp.inf), jnp.zeros((self.population, G)),
                          jnp.zeros(self.population))

    def ask(self, params, state, key, gen):
        x = jnp.clip(state.best + params * jax.random.normal(key, (self.population, G)), -0.8, 0.8)
        return x, dataclasses.replace(state, asked=x)

    def tell(self, params, state, genomes, scores, key, gen):
        f = jnp.where(scores["diverged"], -jnp.inf, scores["fitness"])
        i = jnp.argmax(f)
        better = f[i] > state.best_fitness
        return dataclasses.replace(state, best=jnp.where(better, genomes[i], state.best),
                                   best_fitness=jnp.maximum(f[i], state.best_fitness), distance=scores["distance"])


def test_a_toy_algorithm_runs_beside_the_ga_in_one_program_and_reads_the_outputs_by_name():
    """One GA run and two hill climbers (step 0.3 and 0.1) share each generation's evaluation: the climbers'
    state after ``tell`` holds what ``ask`` left and the output ``distance`` of their own genomes, as the run
    file's metric has it; the GA's rows are bit for bit those of the same run made alone (``cpgjax evolve``)."""
    ga = make_algorithm(PROBLEM, GA)
    climb = HillClimber(kind="climb", population=5, generations=GA.chunk, config={})
    seeds, steps = (5, 6), (0.3, 0.1)
    keys = [run_keys(GA.seed)] + [run_keys(s) for s in seeds]
    params = [stack_params(ga, [ga.params]), stack_params(climb, [jnp.float32(s) for s in steps])]
    # the initial state jitted, as every driver makes it (eagerly, base + spread * noise rounds otherwise)
    states = [jax.tree.map(lambda a: a[None], jax.jit(ga.init)(ga.params, keys[0][0])),
              jax.vmap(climb.init)(params[1], jnp.stack([k[0] for k in keys[1:]]))]
    kps = [keys[0][1][None], jnp.stack([k[1] for k in keys[1:]])]
    kus = [keys[0][2][None], jnp.stack([k[2] for k in keys[1:]])]
    gen0 = [jnp.zeros(1, jnp.int32), jnp.zeros(2, jnp.int32)]
    targets = [jnp.full(1, GA.generations, jnp.int32), jnp.asarray([GA.chunk, 2], jnp.int32)]
    chunk = make_chunk_fn(PROBLEM, [ga, climb], [1, 2], GA.chunk)
    states, rows = jax.device_get(chunk(params, states, kps, kus, gen0, targets))

    c = rows[1]                                       # [generation, run, ...]
    np.testing.assert_array_equal(c["state"]["asked"][:2], c["genomes"][:2])
    np.testing.assert_array_equal(c["state"]["distance"][:2], c["metrics"]["distance"][:2])
    assert set(c["state"]) == {"best", "best_fitness", "asked", "distance"} and np.isnan(c["rate"]).all()
    best = c["state"]["best_fitness"]
    assert np.all(np.diff(best, axis=0) >= 0) and best[-1, 0] > best[0, 0]
    # the second climber's run ends after 2 generations: its state stays as it was after them
    for k, v in c["state"].items():
        np.testing.assert_array_equal(getattr(states[1], k)[1], v[1, 1], err_msg=k)
        np.testing.assert_array_equal(v[-1, 1], v[1, 1], err_msg=k)

    alone = run_ga(PROBLEM, GA)["history"]
    for k, name in (("genomes", "genomes"), ("fitness", "fitness"), ("diverged", "diverged"),
                    ("mutation_rate", "rate")):
        np.testing.assert_array_equal(alone[k][:GA.chunk], rows[0][name][:, 0], err_msg=k)


def test_a_run_file_stores_the_state_by_name_and_another_layout_is_refused_on_resume(tmp_path):
    out = tmp_path / "run.h5"
    run_ga(PROBLEM, GA, out, stop_after=1)
    with h5py.File(out, "a") as f:
        assert set(f["state"]) == {"population"} and f["state/population"].shape == (1, 20, G)
        f.move("state/population", "state/pop")
    with pytest.raises(ResultsError, match=r"cannot resume: the run stores no state 'population' \(it stores pop\)"):
        run_ga(PROBLEM, GA, out, resume=True)
    with h5py.File(out, "a") as f:
        del f["state/pop"]
        f.create_dataset("state/population", data=np.zeros((1, 20, G + 1), np.float32))
    with pytest.raises(ResultsError, match=r"its state 'population' has shape \(20, 11\), this version stores "
                                           r"\(20, 10\)"):
        run_ga(PROBLEM, GA, out, resume=True)


def test_problems_that_differ_by_the_episode_length_alone_lower_to_one_program():
    """The episode's length is an argument of the chunk program (`Problem.length`, `chunk_args`), not a constant in
    it: the GA's programs of the quadruped at two lengths are the same text, so the persistent compilation cache
    holds one (traced and lowered here, not compiled)."""
    from runcases import TINY_TIME

    from cpgjax.experiments.runner import one_run
    from cpgjax.optim.algorithm import chunk_args
    from cpgjax.optim.factory import make_problem

    texts = []
    for T in (TINY_TIME, 2 * TINY_TIME):
        problem = make_problem("models/quadruped.wl", time=T)
        ga = make_algorithm(problem, GAConfig(population=6, generations=2))
        k_init, k_prop, k_upd = run_keys(1)
        state = jax.eval_shape(ga.init, ga.params, k_init)
        args = ([one_run(ga.params)], [jax.tree.map(lambda s: jax.ShapeDtypeStruct((1, *s.shape), s.dtype), state)],
                [k_prop[None]], [k_upd[None]], [jnp.zeros(1, jnp.int32)], [jnp.full(1, 2, jnp.int32)])
        texts.append(make_chunk_fn(problem, [ga], [1], 2).lower(*args, *chunk_args(problem)).as_text())
    assert texts[0] == texts[1]
