"""The closed-loop controller (cpgjax/episode/policy.py): zero weights are the open-loop CPG, latency, the genome."""

import jax
import numpy as np
import pytest
from runcases import TINY_TIME

from cpgjax.episode import policy as pol
from cpgjax.episode import sensors
from cpgjax.episode.batch import evaluate, simulate
from cpgjax.episode.probes import Record
from cpgjax.episode.rollout import rollout
from cpgjax.io.ctl import read_ctl
from cpgjax.io.wl import load_model

QUAD = "models/quadruped.wl"
TROT = "models/quadruped-trot.ctl"


def _trots(model, n=16):
    """The trot and 15 variations of it (N(0, 0.05) on every gene), [n, 8, 5] float32."""
    c = read_ctl(TROT, n_dof=8, harmonics=2).coeffs
    C = np.repeat(c[None], n, 0)
    C[1:] += np.random.default_rng(0).normal(0.0, 0.05, C[1:].shape)
    return C.astype(np.float32)


def _zero_policy(model, C, family=pol.Family()):
    g = np.concatenate([C.reshape(len(C), -1), np.zeros((len(C), family.n_weights(model)), np.float32)], 1)
    return pol.from_genomes(family, model, g)


def _same_bits(model, n):
    C = _trots(model, n)
    open_loop = simulate(model, C[0] if n == 1 else C, time=TINY_TIME)  # one robot: episode/test_rollout.py's program
    closed = simulate(model, _zero_policy(model, C), time=TINY_TIME)
    for k in open_loop:
        np.testing.assert_array_equal(open_loop[k], np.asarray(closed[k]).reshape(np.shape(open_loop[k])), err_msg=k)
    assert n == 1 or np.ptp(open_loop["distance"]) > 0      # different episodes


def test_a_policy_of_zeros_is_the_open_loop_cpg_bit_for_bit():
    """Zero weights: every modulation exactly 0, the phase the CPG's own sin(2 pi k f0 t) (thesis's springs)."""
    _same_bits(load_model(QUAD), 1)


def _batch_of(m, n):
    fam = pol.Family()
    rng = np.random.default_rng(5)
    g = np.concatenate([_trots(m, n).reshape(n, -1), rng.uniform(-0.8, 0.8, (n, fam.n_weights(m)))], 1)
    return pol.from_genomes(fam, m, g.astype(np.float32))


def test_a_closed_loop_robot_gets_the_same_bits_alone_and_in_a_batch():
    """Batch independence (cpgjax/episode/batch.py): a robot's episode does not depend on its neighbours.  32
    robots and one (padded with copies of itself) run one compiled program, the test above's, with other
    neighbours (other batch widths: the slow test below)."""
    m = load_model(QUAD)
    c = _batch_of(m, 32)
    batch = simulate(m, c, time=TINY_TIME)
    assert len(set(batch["distance"].tolist())) == 32                   # 32 different episodes
    for i in (0, 31):
        alone = simulate(m, c[i:i + 1], time=TINY_TIME)
        for k in ("distance", "fitness", "tilt"):
            np.testing.assert_array_equal(alone[k], batch[k][i:i + 1], err_msg=k)


@pytest.mark.slow   # 25 s of CPU (two programs); fast: a robot alone and in a batch on the host's devices
def test_a_closed_loop_robot_gets_the_same_bits_in_chunks_of_16_and_48_on_one_device():
    """The same on one device (the rollout inlined in the caller's program), in chunks of two widths."""
    from functools import partial

    m = load_model(QUAD)
    c = _batch_of(m, 33)
    run = jax.jit(partial(evaluate, m, time=0.2, devices=jax.devices()[:1]))
    a, b = run(c[:16]), run(c)
    for k in ("distance", "fitness", "tilt"):
        np.testing.assert_array_equal(a[k], np.asarray(b[k])[:16], err_msg=k)


@pytest.mark.slow   # 30 s of CPU, most of it compiling; fast: the same for one robot on the thesis's springs
def test_a_policy_of_zeros_is_the_open_loop_cpg_bit_for_bit_on_exact_joints():
    _same_bits(load_model(QUAD, pipeline="exact"), 16)


# the inputs, latency, batch width, thresholds' layout and recording of the two tests below: one compiled program
LATENT = pol.Family(inputs=("tilt", "rates", "contact", "stance", "phase", "bias"))


def _recorded(m, c):
    """``c`` (16 robots, robots first) for 0.05 s, recorded every step, with a latency of one step: its controller
    (batch last) and its trajectory (batch last)."""
    c = jax.tree.map(lambda a: np.moveaxis(a, 0, -1), c)
    r = jax.jit(lambda cc: rollout(m, cc, time=0.05, log_rate=1.0 / m.dt, probes=(Record(),), latency=1))(c)
    return c, jax.tree.map(np.asarray, r["traj"])


def test_latency_delays_the_action_by_exactly_one_step():
    """With latency, the action of step n is the policy of the observation of step n - 1 (recorded every step)."""
    m = load_model(QUAD)
    rng = np.random.default_rng(1)
    g = np.concatenate([_trots(m, 1).reshape(1, -1), rng.uniform(-0.8, 0.8, (1, LATENT.n_weights(m)))], 1)
    zero = np.zeros((16, 4), np.float32)      # the sensors' own threshold, given: the touch test's program
    c, r = _recorded(m, pol.from_genomes(LATENT, m, np.repeat(g, 16, 0).astype(np.float32), touch=zero))
    tr = jax.tree.map(lambda a: a[..., 0], r)
    obs = tr["obs"]                                       # [S, in]: sample k's observation (of step k, t = 0 twice)
    W = np.asarray(c.weights)[..., 0].astype(np.float64)
    u = obs.astype(np.float64) @ W.T                      # the policy of each observation
    off = np.clip(u[:, : m.n_ctrl], *pol.LIMITS["offsets"])
    mf = np.clip(u[:, m.n_ctrl], *pol.LIMITS["frequency"])
    # sample k >= 1 records step k - 1's action: with latency it is the policy of step k - 2's observation
    np.testing.assert_allclose(tr["offsets"][2:], off[1:-1], rtol=0, atol=2e-6)
    np.testing.assert_allclose(tr["frequency"][2:], mf[1:-1], rtol=0, atol=2e-6)
    assert np.abs(tr["offsets"][2:] - off[2:]).max() > 1e-3         # not the step's own observation
    # the phase offset integrates the frequency modulation: d(k) = sum of dt m_f over the steps before
    np.testing.assert_allclose(tr["phase"][1:], np.cumsum(tr["frequency"][1:]) * m.dt, rtol=1e-5, atol=1e-9)


def test_the_touch_sensors_read_from_each_controllers_own_threshold_in_the_episode():
    """``ClosedLoop.touch`` reaches the sensors in the scan: the recorded contact readings of 16 robots, one
    controller (zero weights: the trot), thresholds of 10 cm above the ground (every foot down: the trot lifts its feet
    less), 1 cm in (none: a foot carrying its share of the robot sinks 0.3 mm) and 0 (the sensors' own: with none
    given they read from 0, episode/test_sensors.py), and their ``stance`` low-pass.  The latency test's program."""
    m = load_model(QUAD)
    g = np.concatenate([_trots(m, 1).reshape(1, -1), np.zeros((1, LATENT.n_weights(m)))], 1)
    at = np.repeat(np.float32([[-0.1], [0.01], [0.0], [0.0]]), 4, 1)        # [4 thresholds, legs]
    c = pol.from_genomes(LATENT, m, np.repeat(g, 16, 0).astype(np.float32), touch=np.tile(at, (4, 1)))
    edges = np.cumsum([0] + [n for _, n in LATENT.input_sizes(m)])
    rec = _recorded(m, c)[1]["obs"]
    obs, stance = rec[:, edges[2]:edges[3]], rec[:, edges[3]:edges[4]]      # [S, legs, robots]
    assert (obs[..., 0::4] == 1).all() and (obs[..., 1::4] == 0).all()
    assert 0 < obs[..., 2].mean() < 1                                       # the trot lifts its feet in turn
    np.testing.assert_array_equal(obs[..., 2::4], np.repeat(obs[..., 2:3], 4, -1))     # one controller: one episode
    np.testing.assert_array_equal(obs[..., 3::4], np.repeat(obs[..., 2:3], 4, -1))
    # ``stance`` low-passes the same readings step by step (sensors.stance_update), from the first one on: MuJoCo C's
    # runner does the same (crosscheck/test_engines.py).  Tolerance: one float32 rounding.
    np.testing.assert_array_equal(stance[..., 0::4], 1.0)
    np.testing.assert_array_equal(stance[..., 1::4], 0.0)
    a = m.dt / sensors.STANCE_TAU
    s, x = stance[..., 2], obs[..., 2]
    assert np.abs(np.diff(x, axis=0)).sum() >= 2 and ((s > 0) & (s < 1)).any()     # feet land and lift
    np.testing.assert_array_equal(s[0], x[0])
    np.testing.assert_allclose(s[1:], s[:-1] + a * (x[1:] - s[:-1]), rtol=0, atol=1e-6)


def test_the_genome_is_the_cpg_then_the_policy_genes_scaled():
    m = load_model(QUAD)
    fam = pol.parse_controller("pmtg:tilt+contact+bias")
    assert fam.inputs == ("tilt", "contact", "bias") and fam.spec == "pmtg:tilt+contact+bias"
    assert (fam.n_in(m), fam.n_out(m), fam.n_genes(m)) == (7, 10, 40 + 70)
    g = np.random.default_rng(2).uniform(-0.8, 0.8, (3, fam.n_genes(m))).astype(np.float32)
    c = pol.from_genomes(fam, m, g)
    np.testing.assert_array_equal(c.coeffs, g[:, :40].reshape(3, 8, 5))
    scale = pol.weight_scale(fam, m)
    # offset per tilt, frequency per bias, amplitude per contact
    assert scale[0, 0] == 0.5 / 0.5 and scale[8, 6] == 1.0 and scale[9, 2] == 0.5
    np.testing.assert_array_equal(c.weights, g[:, 40:].reshape(3, 10, 7) * scale)
    np.testing.assert_allclose(pol.to_genome(c[1], m), g[1], rtol=1e-6)
    assert pol.parse_controller("cpg") is None and pol.parse_controller(None) is None
    for bad in ("pmtg:tilt+wings", "cpg:tilt", "ann"):
        with pytest.raises(ValueError):
            pol.parse_controller(bad)
