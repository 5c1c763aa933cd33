"""Steering by a commanded turning rate (beyond the thesis; its Ch. 7.5): where the command comes from, and how well
a walk follows it.

A closed-loop policy (:mod:`cpgjax.episode.policy`) reads a commanded turning rate ``c`` (rad/s, + = left) in its
``command`` and ``steer`` groups (:mod:`cpgjax.episode.sensors`).  The command is computed inside the episode's
scan, every integration step, by one of two sources (a pytree carried by the controller,
:attr:`cpgjax.episode.policy.ClosedLoop.steer`, its arrays batch-last as the controller's):

- :class:`Schedule` (evolving a gait that follows a command; the robust evaluation's ``command`` perturbation):
  ``c = first`` until ``switch`` s, then ``c = second``, both drawn per episode, so that a policy learns to walk
  a turn and to change it;
- :class:`Course` (walking a path with the gait alone): the robot's own pose sets the command, as a robot with an
  IMU and odometry could: the heading error ``e`` to the next waypoint (:func:`heading_error`), ``c = clip(k e,
  -limit, limit)`` (:func:`command_law`), a waypoint passed when the tracked body's CM comes within ``reach`` of
  it, ``c = 0`` after the last.  No look-ahead, no simulation of what a command will do.

**Tracking** (:func:`track_init`, :func:`track_update`, :func:`track_finish`; the rollout runs them at every log
sample under a :class:`Schedule`): the heading ``psi`` of the tracked body (as :func:`cpgjax.episode.descriptors.
heading`) unwrapped sample to sample; the progress along it, the CM's displacement between samples projected on
the heading at the mid-angle, weighted by the vestibular stability ``S`` of the sample (eq. 6.2: eq. 4.5 with the
speed along the heading instead of along +y, since a robot that turns as told does not walk along +y); the
turning per phase of the schedule.  Both stop at a fall, as eq. 4.6's sum does.  The episode's
**heading fitness** is the progress over the episode's length (m/s) and its **turn error** the mean over the two
phases of ``|mean turning rate - c|`` (rad/s).  The **tracking fitness** (:func:`tracking_fitness`) is

    heading fitness x max(0, 1 - turn error / limit)

a product, not a difference: a gait that does not move scores 0 whatever it turns (a difference would let a
robot that stands and turns on the spot score above one that walks), a gait that walks straight when told to
turn by ``limit`` (the command's range) scores 0, and between the two the score falls linearly with the error,
in the units of the speed it is made of (no weight between metres and radians to choose).  With a **speed cap**
``v_max`` (``--perturb command=R,speed=V``) the heading fitness is credited up to ``v_max`` only, ``min(heading
fitness, v_max)``: past it a gait gains only by following the command better (and, with ``fall_zero``, by not
falling), not by walking faster.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.episode import descriptors as bd
from cpgjax.episode.descriptors import wrap
from cpgjax.sim.rotation import quat_to_mat
from cpgjax.sim.state import sim_time

GAIN = 1.0       # 1/s: the follower's proportional gain (a heading error of 0.3 rad commands 0.3 rad/s)
REACH = 0.2      # m: a waypoint is passed when the tracked body's CM comes this close (as `cpgjax follow`'s)
TOLERANCE = 0.5  # the turn error, as a share of the command's range, at which the tracking fitness reaches 0


def heading_of(model, s):
    """Heading [B] of the tracked body (`descriptors.heading`, from its orientation alone) and its CM in the ground
    plane [2, B]."""
    return bd.forward_heading(quat_to_mat(s.q[:, model.track])[:, 1]), s.x[:2, model.track]


def heading_error(xy, psi, target):
    """The angle [B] from the heading ``psi`` to the bearing of ``target`` [2, B] seen from ``xy`` [2, B], wrapped
    to (-pi, pi] (+: the target is to the left)."""
    d = target - xy
    return wrap(jnp.arctan2(-d[0], d[1]) - psi)


def command_law(err, gain: float = GAIN, limit: float = 0.4):
    """The follower's commanded turning rate: ``clip(gain err, -limit, limit)`` (rad/s)."""
    return jnp.clip(gain * err, -limit, limit)


@jax.tree_util.register_pytree_node_class
class Schedule:
    """A commanded turning rate per robot: ``first`` [B] until ``switch`` s, then ``second`` [B] (rad/s).

    ``switch=None``: the episode's length as data holds it (:func:`switch_length`; the rollout sets it, a traced
    scalar, on the copy it runs: :meth:`at`)."""

    def __init__(self, first, second, switch: float | None, limit: float):
        self.first, self.second, self.limit = first, second, float(limit)
        self.switch = None if switch is None else float(switch)

    def at(self, switch) -> Schedule:
        """This schedule switching at ``switch`` (a traced scalar; not to be flattened as a pytree)."""
        out = Schedule(self.first, self.second, None, self.limit)
        out.switch = switch
        return out

    def tree_flatten(self):
        return (self.first, self.second), (self.switch, self.limit)

    @classmethod
    def tree_unflatten(cls, aux, leaves):
        return cls(*leaves, *aux)

    def init(self, model, s0):
        return {}

    def command(self, model, s, mem):
        return jnp.where(sim_time(model, s) < self.switch, self.first, self.second), mem


@jax.tree_util.register_pytree_node_class
class Course:
    """A path to follow per robot: ``points`` [P, 2, B] (m; padded by repeating the last), ``count`` [B] int32 the
    waypoints of each robot's path; the law's ``gain`` (1/s), ``limit`` (rad/s) and ``reach`` (m)."""

    def __init__(self, points, count, gain: float = GAIN, limit: float = 0.4, reach: float = REACH):
        self.points, self.count = points, count
        self.gain, self.limit, self.reach = float(gain), float(limit), float(reach)

    def tree_flatten(self):
        return (self.points, self.count), (self.gain, self.limit, self.reach)

    @classmethod
    def tree_unflatten(cls, aux, leaves):
        return cls(*leaves, *aux)

    def init(self, model, s0):
        return {"waypoint": jnp.zeros(s0.x.shape[-1:], jnp.int32)}

    def _target(self, k):
        kk = jnp.minimum(k, self.points.shape[0] - 1)
        return jnp.take_along_axis(self.points, kk[None, None], axis=0)[0]

    def command(self, model, s, mem):
        """The command [B] at state ``s`` and the waypoint memory (the next waypoint's index, passed ones counted)."""
        psi, xy = heading_of(model, s)
        k = mem["waypoint"]
        d = self._target(k) - xy
        k = k + ((jnp.sqrt(d[0] ** 2 + d[1] ** 2) < self.reach) & (k < self.count)).astype(k.dtype)
        c = command_law(heading_error(xy, psi, self._target(k)), self.gain, self.limit)
        return jnp.where(k < self.count, c, jnp.zeros_like(c)), {"waypoint": k}


def course(paths: list[np.ndarray], gain: float = GAIN, limit: float = 0.4, reach: float = REACH) -> Course:
    """A :class:`Course` of robots first (points [N, P, 2], count [N]) from each robot's waypoints [n_i, 2]."""
    P = max(len(p) for p in paths)
    pts = np.stack([np.concatenate([p, np.repeat(p[-1:], P - len(p), 0)]) for p in paths]).astype(np.float32)
    return Course(pts, np.asarray([len(p) for p in paths], np.int32), gain, limit, reach)


def track_init(psi, xy):
    """The tracking sums at t = 0 (``psi`` [B] the heading, ``xy`` [2, B] the CM in the ground plane)."""
    z = jnp.zeros_like(psi)
    return {"psi": psi, "xy": xy, "advance": z, "turn0": z, "turn1": z}


def track_update(acc, psi, xy, S, second, up):
    """One log sample: heading ``psi`` [B], CM ``xy`` [2, B], stability ``S`` [B]; ``second`` (bool) whether the
    sample is in the schedule's second phase; ``up`` [B] whether the robot still scores (not fallen, not diverged)."""
    d, adv = bd.heading_step(acc["psi"], acc["xy"], psi, xy)      # as the descriptors' sums
    d_up = jnp.where(up, d, 0.0)
    return {"psi": psi, "xy": xy, "advance": acc["advance"] + jnp.where(up, adv * S, 0.0),
            "turn0": acc["turn0"] + jnp.where(second, 0.0, d_up), "turn1": acc["turn1"] + jnp.where(second, d_up, 0.0)}


def track_finish(acc, T: float, switch: float, first, second, length=None):
    """``(heading fitness [B] m/s, turn error [B] rad/s)`` of an episode of ``T`` s switching at ``switch`` s, or
    of the episode's ``length`` as data (:func:`switch_length`'s entries in it; ``T`` and ``switch`` unused)."""
    if length is not None:   # the reciprocals rounded on the host as XLA rounds those of the constants
        err = jnp.abs(acc["turn0"] * length["per_switch"] - first)
        err = jnp.where(length["rest"] > 0, 0.5 * (err + jnp.abs(acc["turn1"] * length["per_rest"] - second)), err)
        return acc["advance"] * length["per_second"], err
    err = jnp.abs(acc["turn0"] / switch - first)
    if T > switch:
        err = 0.5 * (err + jnp.abs(acc["turn1"] / (T - switch) - second))
    return acc["advance"] / T, err


def switch_length(switch: float, T: float) -> dict:
    """A :class:`Schedule`'s switch for the episode's length as data (:func:`cpgjax.episode.rollout.episode_length`,
    whose ``T`` s the episode spans): float32 numpy scalars ``switch``, ``rest`` (``T - switch``) and their
    reciprocals (0 for a ``rest`` of 0)."""
    sw, rest = np.float32(switch), np.float32(T - switch)
    return {"switch": sw, "rest": rest, "per_switch": np.float32(1.0) / sw,
            "per_rest": np.float32(1.0) / rest if rest > 0 else np.float32(0.0)}


def overcharge(speed, cap, over: float):
    """What ``speed`` going past ``cap`` (m/s) costs the score: ``over max(0, speed - cap)``."""
    return over * jnp.maximum(speed - cap, 0.0)


def capped(speed, cap, over: float = 0.0):
    """``speed`` credited up to ``cap`` (m/s), less ``over`` times what it goes past the cap:
    ``min(speed, cap) - over max(0, speed - cap)`` (``over = 1``: ``cap - |speed - cap|`` past the cap, the score
    peaking at the cap).  Eq. 4.6's fitness under ``--perturb speed=V,overspeed=K`` without a command."""
    out = jnp.minimum(speed, cap)
    return out - overcharge(speed, cap, over) if over > 0 else out


def tracking_fitness(heading_fitness, turn_error, limit: float, cap: float = 0.0, over: float = 0.0,
                     tolerance: float = TOLERANCE):
    """``heading_fitness x max(0, 1 - turn_error / (tolerance limit))``, the heading fitness taken up to ``cap`` m/s
    when ``cap > 0`` (a number, or one per episode; see the module docstring); then, with ``over``, less ``over``
    times what it goes past the cap, whatever the turn error (charged after the product, so that a gait too fast
    for its turn scores less when it ignores the command too, not 0).  ``tolerance``: the turn error, as a share of
    the command's range, at which the factor reaches 0 (``--perturb turn_tolerance``)."""
    follow = jnp.maximum(0.0, 1.0 - turn_error / (tolerance * limit))
    if isinstance(cap, (int, float)) and cap <= 0:
        return heading_fitness * follow
    score = jnp.minimum(heading_fitness, cap) * follow     # cap, an array: one per episode (perturb turn_speed)
    return score - overcharge(heading_fitness, cap, over) if over > 0 else score
