"""Behaviour descriptors of an episode, accumulated online in the rollout's scan (no trajectory stored).

Beyond the thesis: the behaviour space of a quality-diversity repertoire (Cully et al., *Robots that can
adapt like animals*, Nature 2015; :mod:`cpgjax.optim.mapelites`).  Two descriptors, both sums carried by
:func:`cpgjax.episode.rollout.rollout` (the probe :class:`~cpgjax.episode.probes.Descriptors`) from one log
sample to the next:

- **duty factor of each leg**: the share of the episode's log samples at which the leg's foot touches
  the ground (Cully's descriptor).  A *leg* is a chain of bodies hanging from the tracked body (the
  torso) by a joint; its *foot* is the contact vertices of the chain's last body; it touches when any
  of them is below the terrain (depth > 0, the contact law's own test, as in
  :mod:`cpgjax.episode.support`).  A foot always down has duty factor 1.
- **forward speed x turning rate**: the heading ``psi`` of the tracked body (the angle of its forward
  axis, body +y, in the ground plane, counter-clockwise from world +y) is unwrapped sample to sample;
  the turning rate is its total change over the episode's length (rad/s, + = turning left).  The
  forward speed is the displacement of the tracked body's CM between samples projected on the heading
  at the midpoint angle, summed, over the episode's length (m/s): on a circle of radius ``r`` walked at
  speed ``v`` the turning rate is exactly ``v / r`` and the speed ``v`` to ``O(dpsi^2 / 24)`` (each
  step's chord is parallel to the tangent at the mid-angle).

The sums live in a small dict (:func:`init`, :func:`update`, :func:`finish`): pure functions of the
samples, so that a test can feed them a hand-made episode as well as a simulated one.
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

DESCRIPTORS = ("duty", "speed-turn")


def _children(model) -> dict[int, list[int]]:
    out: dict[int, list[int]] = {}
    for a, b in zip(np.asarray(model.j_a).tolist(), np.asarray(model.j_b).tolist(), strict=True):
        out.setdefault(int(a), []).append(int(b))
    return out


def legs(model) -> tuple[tuple[str, ...], np.ndarray, tuple[tuple[int, ...], ...]]:
    """The legs of a model: ``(names, feet [L, nc] bool, bodies)``.

    A leg starts at each joint whose first body is the tracked body; its name is that joint's name without
    the prefix all those joints share (``HipAR`` ... ``HipPL`` -> ``AR`` ... ``PL``).  ``feet[l]`` marks the
    contact vertices of the leg's last body (its foot); ``bodies[l]`` every body of the leg.
    """
    kids = _children(model)
    roots = [j for j in range(model.nj) if int(model.j_a[j]) == int(model.track)]
    names = [model.joint_names[j] for j in roots]
    cut = 0
    while len(names) > 1 and all(len(n) > cut + 1 and n[cut] == names[0][cut] for n in names):
        cut += 1
    pt_body = np.asarray(model.pt_body)[np.asarray(model.ct_pt)]
    feet, bodies = np.zeros((len(roots), len(pt_body)), bool), []
    for i, j in enumerate(roots):
        chain, b = [], int(model.j_b[j])
        while True:
            chain.append(b)
            nxt = kids.get(b, [])
            if not nxt:
                break
            b = nxt[0]
        seen, stack = [], [int(model.j_b[j])]   # every body below the root joint (branches included)
        while stack:
            c = stack.pop()
            seen.append(c)
            stack.extend(kids.get(c, []))
        bodies.append(tuple(sorted(seen)))
        feet[i] = pt_body == chain[-1]
    return tuple(n[cut:] for n in names), feet, tuple(bodies)


def names(model, descriptor: str) -> tuple[str, ...]:
    """The names of a descriptor's dimensions: ``duty_AR ...`` (one per leg) or ``speed, turn``."""
    if descriptor == "duty":
        return tuple(f"duty_{n}" for n in legs(model)[0])
    if descriptor == "speed-turn":
        return ("speed", "turn")
    raise ValueError(f"unknown descriptor {descriptor!r}: expected one of {', '.join(DESCRIPTORS)}")


def wrap(a):
    """An angle wrapped to (-pi, pi]."""
    return jnp.arctan2(jnp.sin(a), jnp.cos(a))


def forward_heading(f):
    """The angle in the ground plane of a body's forward axis ``f`` [3, B] (its +y in world coordinates),
    counter-clockwise from world +y (rad)."""
    return jnp.arctan2(-f[0], f[1])


def heading(model, R):
    """Heading [B] of the tracked body: the angle of its forward axis (body +y) in the ground plane,
    counter-clockwise from world +y (rad)."""
    return forward_heading(R[:, 1, model.track])          # the body's +y axis in world coordinates [3, B]


def heading_step(psi0, xy0, psi, xy):
    """From one log sample to the next (heading ``psi0`` -> ``psi`` [B], CM in the ground plane ``xy0`` -> ``xy``
    [2, B]): the turn, wrapped to (-pi, pi] (samples are far apart less than pi), and the advance along the mean
    heading (m)."""
    d = wrap(psi - psi0)
    mid = psi0 + 0.5 * d
    step = xy - xy0
    return d, -jnp.sin(mid) * step[0] + jnp.cos(mid) * step[1]


def init(model, x0, R0, n_legs: int):
    """The sums at t = 0 (``x0`` [3, nb, B] CM positions, ``R0`` [3, 3, nb, B])."""
    B = x0.shape[-1]
    z = jnp.zeros((B,), x0.dtype)
    return {"touch": jnp.zeros((n_legs, B), x0.dtype), "psi": heading(model, R0), "turn": z, "advance": z,
            "xy": x0[:2, model.track]}


def update(acc, feet, down, psi, xy):
    """One log sample: ``down`` [nc, B] which contact vertices touch, ``psi`` [B] the heading,
    ``xy`` [2, B] the tracked body's CM in the ground plane."""
    touch = (jnp.asarray(feet, down.dtype) @ down) > 0 if feet.shape[0] else jnp.zeros((0,) + down.shape[1:], bool)
    d, adv = heading_step(acc["psi"], acc["xy"], psi, xy)
    return {"touch": acc["touch"] + touch, "psi": psi, "turn": acc["turn"] + d,
            "advance": acc["advance"] + adv, "xy": xy}


def finish(acc, per_sample, per_second):
    """``{"duty": [L, B], "speed": [B], "turn": [B]}`` from the sums over the log samples: ``per_sample(a)`` is a
    sum over the number of samples, ``per_second(a)`` one over the episode's seconds
    (:func:`cpgjax.episode.rollout.rollout`)."""
    return {"duty": per_sample(acc["touch"]), "speed": per_second(acc["advance"]), "turn": per_second(acc["turn"])}
