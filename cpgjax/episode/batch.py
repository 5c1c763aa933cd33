"""Batching an episode across devices: padding, `shard_map` over the host devices, a jit cache.

:func:`cpgjax.episode.rollout.rollout` is pure and runs one batch on one device.  This module
is the one place that knows about devices and compilation: :func:`evaluate` (traceable) pads
the batch, splits it across the host devices (one per CPU core, see `cpgjax._xla`) and runs
the rollout chunk by chunk; :func:`simulate` is the host-side convenience (numpy in and out)
with a cache of compiled programs.
"""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.episode.policy import batch_size, is_closed
from cpgjax.episode.probes import Record
from cpgjax.episode.rollout import episode_length, rollout
from cpgjax.episode.steering import Schedule

# Robots are padded to a multiple of LANES per chunk.  Why: XLA's CPU code computes
# full SIMD vectors and a scalar (or narrower) tail differently (vectorised vs scalar
# transcendentals, FMA contraction), so a robot's result could depend on where in the
# batch it sat.  With every chunk a whole number of 16-float vectors (AVX-512; a
# multiple of AVX2's 8), every robot runs the same instructions and a batch of N is
# bitwise equal to N single runs (tests/test_episode.py).
LANES = 16


def lanes(model, n: int) -> int:
    """The width of a batch of ``n`` robots on one device: ``n`` padded to whole SIMD vectors (:data:`LANES`),
    and on exact joints to a power of two of them.

    Why the power of two: the exact pipeline's step (`sim.exact`) gave a robot the same bits in batches
    of 16, 32, 64, 128, 256 and 512 robots but not of 48, 80, 96 or 192 (44-102 of the first robots
    differed in their last bits: XLA's CPU code splits such widths into vector loops differently); the
    thesis's pipeline is the same at every multiple of 16 (tests/episode/test_rollout.py).  The price: up to
    twice the robots computed for a batch just over a power of two.
    """
    w = -(-max(n, 1) // LANES) * LANES
    if model.pipeline == "exact":
        w = LANES << max(0, (w // LANES - 1).bit_length())
    return w


def chunk_width(model, per_dev: int, chunk: int) -> int:
    """The width of the chunks that run a device's ``per_dev`` robots, at most ``chunk`` wide: :func:`lanes`'s,
    and on exact joints the power of two (of SIMD vectors) that pads them least, ties to the narrowest, not below
    8 vectors (128 robots: narrower chunks are bound by kernel launches, and a robot-step of 64 costs more than
    the padding it saves).

    Why: every power of two gives a robot the same bits (:func:`lanes`), so the choice is free; the widest one
    that fits can waste nearly half a chunk.  ``make thesis``'s sweep (600 robots per device) ran 3 chunks of
    256 (768 robots) where 5 of 128 run 640, a robot-step costing about as much at 128 as at 256.  Ties go to
    128, where a batch of 1024 runs as fast as a batch of 256 (in chunks of 256 the larger batch was the slower
    one).  The figures: docs/results/performance-exact.md (*Its step in MuJoCo's stages*, *A batch of 1024 as
    fast as 256*).
    """
    w = lanes(model, min(chunk, per_dev))
    if model.pipeline != "exact":
        return w
    best, cand = w, w
    while cand // 2 >= 8 * LANES:
        cand //= 2
        if -(-per_dev // cand) * cand <= -(-per_dev // best) * best:
            best = cand
    return best


def padded_size(model, n: int, chunk: int, devices: int) -> tuple[int, int]:
    """(robots computed, chunk width) for a batch of ``n`` robots on ``devices`` host devices: every device runs
    whole chunks of :func:`chunk_width`."""
    per_dev = -(-n // devices)
    ch = chunk_width(model, per_dev, chunk)
    return -(-per_dev // ch) * ch * devices, ch


def _chunked(model, inputs, length=None, *, chunk, **kw):
    """Evaluate [n_chunks * chunk] robots chunk by chunk (lax.map) on one device.

    ``inputs = (coeffs, var)``: batch-last arrays (``var`` may be None); ``length``: the episode's length as data
    (:func:`cpgjax.episode.rollout.episode_length`), or None (``kw``'s ``time``).
    """
    def split(a):
        a = a.reshape(a.shape[:-1] + (a.shape[-1] // chunk, chunk))
        return jnp.moveaxis(a, -2, 0)

    if length is not None:
        kw = kw | {"length": length}
    out = jax.lax.map(lambda cv: rollout(model, cv[0], var=cv[1], **kw), jax.tree.map(split, inputs))
    # robots first (for shard_map's out_specs; a no-op on the [N] results), batch-last again in `evaluate`
    return jax.tree.map(lambda a: jnp.moveaxis(jnp.moveaxis(a, 0, -2).reshape(a.shape[1:-1] + (-1,)), -1, 0), out)


def evaluate(model, coeffs, *, chunk: int = 256, devices=None, var=None, length=None, **kw):
    """Traceable batched evaluation of coeffs [N, n_ctrl, 2K+1] (or a :class:`~cpgjax.episode.policy.ClosedLoop`
    of N controllers, robots first) on all local devices.

    Pads N to a multiple of ``devices * chunk`` (repeating the last controller), splits the
    robots across host devices with `shard_map`, and runs `rollout` in chunks on each.
    ``var``: an optional per-robot :class:`~cpgjax.sim.variation.Variation` (batch-last, [..., N]),
    padded and split with the robots.  ``length``: the episode's length as data
    (:func:`cpgjax.episode.rollout.episode_length`, traced or not; instead of ``time``), passed to every device:
    one compiled program for every episode length.  Returns the dict of `rollout` (without trajectories), each
    [..., N] (``[N]`` for the scores; ``[samples, N]`` for the series of the probe
    :class:`~cpgjax.episode.probes.Stability`).
    """
    devs = jax.devices() if devices is None else devices
    N = batch_size(coeffs)
    # Always every device, even for a batch that fits one SIMD vector: a batch on one device ran inline
    # in the caller's program, and XLA then fused the robust evaluation's inputs into it differently from
    # a sharded batch (a sweep's run differed from the same run alone in the last bits).
    nd = len(devs)
    total, ch = padded_size(model, N, chunk, nd)
    x = (jax.tree.map(lambda a: jnp.moveaxis(a, 0, -1), coeffs), var)  # batch-last
    if total > N:
        x = jax.tree.map(lambda a: jnp.concatenate([a, jnp.repeat(a[..., -1:], total - N, -1)], -1), x)
    fn = partial(_chunked, model, chunk=ch, **kw)
    if nd > 1:
        mesh = jax.sharding.Mesh(np.asarray(devs), ("d",))
        P = jax.sharding.PartitionSpec
        specs = jax.tree.map(lambda a: P(*([None] * (a.ndim - 1)), "d"), x)
        if length is None:
            fn = jax.shard_map(fn, mesh=mesh, in_specs=(specs,), out_specs=P("d"), check_vma=False)
        else:   # the length: the same scalars on every device
            fn = jax.shard_map(fn, mesh=mesh, in_specs=(specs, jax.tree.map(lambda _: P(), length)),
                               out_specs=P("d"), check_vma=False)
    out = fn(x) if length is None else fn(x, length)
    return jax.tree.map(lambda a: jnp.moveaxis(a[:N], 0, -1), out)


def simulate(model, coeffs, *, time=None, delta=8.0, record=False, chunk: int = 256):
    """Host-side convenience: numpy in, numpy out, one compiled program per padded width (:func:`padded_size`)
    and setting, whatever the episode's length (``time``, passed as data:
    :func:`~cpgjax.episode.rollout.episode_length`).

    coeffs: [N, n_ctrl, 2K+1] (or [n_ctrl, 2K+1] for one robot), or a
    :class:`~cpgjax.episode.policy.ClosedLoop` of N controllers (or of one, without the robot axis).  With
    ``record=True`` the robots run in one batch on one device and the result has ``traj`` (its shape depends on
    the length: one program per episode length).
    """
    c = jax.tree.map(lambda a: np.asarray(a, np.float32 if np.issubdtype(np.asarray(a).dtype, np.floating)
                                          else np.asarray(a).dtype), coeffs)
    single = (c.coeffs if is_closed(c) else c).ndim == 2
    if single:
        c = jax.tree.map(lambda a: a[None], c)
    n = batch_size(c)
    if record:
        pad = lanes(model, n) - n
        c = jax.tree.map(lambda a: np.concatenate([a, np.repeat(a[-1:], pad, 0)]), c) if pad else c
        f = jax.jit(lambda cc: rollout(model, jax.tree.map(lambda a: jnp.moveaxis(a, 0, -1), cc), time=time,
                                       delta=delta, probes=(Record(),)))
        out = jax.tree.map(np.asarray, f(c))
        out = {k: (v[..., :n] if k != "traj" else {kk: (vv[..., :n] if kk != "t" else vv) for kk, vv in v.items()})
               for k, v in out.items()}
    else:
        # padded here as `evaluate` pads (the last controller repeated), so that every batch size padded to the
        # same width runs one compiled program
        pad = padded_size(model, n, chunk, len(jax.devices()))[0] - n
        c = jax.tree.map(lambda a: np.concatenate([a, np.repeat(a[-1:], pad, 0)]), c) if pad else c
        c, switch = _switch_as_data(c)
        r = _jitted_evaluate(model, delta, chunk)(c, episode_length(model, time, switch=switch))
        out = jax.tree.map(lambda a: np.asarray(a)[..., :n], r)
    if single:
        out = jax.tree.map(lambda a: a[..., 0] if a.ndim and a.shape[-1] == 1 else a, out)
    return out


def _switch_as_data(c):
    """``(c, switch)``: a closed loop steered by a :class:`~cpgjax.episode.steering.Schedule` with its switch time
    given, with the switch left to the episode's length (None), and that time; else ``(c, None)``."""
    steer = c.steer if is_closed(c) else None
    if not isinstance(steer, Schedule) or steer.switch is None:
        return c, None
    return c.replace(steer=Schedule(steer.first, steer.second, None, steer.limit)), steer.switch


_CACHE: dict = {}


def _jitted_evaluate(model, delta, chunk):
    """``f(coeffs, length)``: :func:`evaluate` jitted, the episode's length (:func:`episode_length`) an argument."""
    key = (model, delta, chunk)      # the model's structure (sim.fingerprint): a model loaded again shares it
    if key not in _CACHE:
        _CACHE[key] = jax.jit(lambda c, length: evaluate(model, c, length=length, delta=delta, chunk=chunk))
    return _CACHE[key]
