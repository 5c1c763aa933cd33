"""The robust evaluation's perturbations: what a controller must survive to score (docs/evolution.md).

The thesis scored a controller by one exact episode (eq. 4.6).  The penalty simulator, like any
simulator of a statically unstable walker, is sensitive to small differences, so one exact
episode rewards controllers that are *lucky*: they score in that episode and fall in any other
(and on the "robot", MuJoCo).  The robust evaluation scores each controller as the mean over R
episodes, each with fresh perturbations drawn per robot from its own key:

* the initial pose: the whole robot lifted by ``U(-lift, lift)`` and rolled and pitched by
  ``U(-tilt, tilt)``;
* the terrain (off by default: a heightfield is slower than the flat ground's fast path,
  docs/results/performance.md, *Where the step's time goes*): a heightfield
  of uniform roughness in ``[0, roughness]`` (0.1 m cells) added to the model's terrain, the robot
  placed at a random spot of it; with ``texture`` also a fine relief in ``[0, texture]`` on 2.5 cm cells, on which
  a foot that skims the ground in its swing catches, as it does on MuJoCo's triangulated ground;
* the robot as built: friction coefficients, each body's mass and inertia, and each servo's gains
  scaled by ``1 + U(-x, x)`` (``friction``, ``mass``, ``gain``);
* the foot's compliance (off by default): the friction bristle's spring ``k`` (``FrictionSpring``) scaled
  by ``10^U(bristle_from, bristle)``, from the model's soft default (``bristle_from`` 0) up to ``bristle`` decades
  stiffer: the soft
  bristle lets a gait store and return energy in centimetres of elastic foot slip that MuJoCo's
  friction does not have (docs/simulator.md), and a gait that must work at every stiffness cannot
  live on it;
* the controller: every gene moved by ``U(-sqrt(3) jitter, sqrt(3) jitter)`` (standard deviation
  ``jitter``; clipped to the search box);
* (off by default) the servos' torque limit scaled by ``1 + U(-torque, torque)`` per servo; the ground's stiffness
  A and damping B (eq. 3.7, where MuJoCo's contact differs from ours) by ``1 + U(-x, x)`` (``stiffness``,
  ``damping``); the rough field's relief (``relief``): its heights scaled by ``1 - U(0, relief)`` per episode, so
  that with ``relief=1`` an episode's ground is anywhere from flat to ``roughness`` rough, at a random spot of the
  field (on stairs, a bar or a gap, ``sim.ledges``, their heights too, with or without ``roughness``);
* (off by default) a shove (``push``): once per episode, at a time drawn from :data:`PUSH_WINDOW` of it, every
  body's velocity changes by ``(U(-push, push), U(-push, push), 0)`` m/s (a horizontal impulse on the whole robot,
  applied by the rollout, :func:`cpgjax.episode.rollout.rollout`), so that a gait must recover from a stumble;
* (closed-loop controllers, :mod:`cpgjax.episode.policy`) the sensors: noise of ``noise`` times each sensor's
  scale (standard deviation), drawn per robot and step, and a ``latency`` of 0 or 1 step between the observation
  and the action;
* (closed-loop controllers that read the ``command``) the task: a commanded turning rate ``U(-command, command)``
  rad/s for the first half of the episode and another for the second (:func:`commands`,
  :class:`cpgjax.episode.steering.Schedule`), the episode scored by how well it follows them
  (:func:`cpgjax.episode.steering.tracking_fitness`) instead of eq. 4.6; ``speed`` (m/s, 0: none) caps the speed
  the score credits (without a command, eq. 4.6's).

**Domain randomisation** is the named preset :data:`PRESETS` ``domain`` (``--perturb preset=domain``): every range
above at once, wide (docs/evolution.md); keys given beside it override its values.

A fall (the body tilted past 60 degrees, or past ``fall_tilt`` degrees: a margin below the tilt at which the
judges, ``follow``, ``transfer`` and MuJoCo C's replays, call a fall) ends the episode's score (``fall_ends``, on
by default), or
forfeits it (``fall_zero``: the episode scores 0, so the mean over the R episodes is the controller's
speed times the share of episodes it stays up in: a gait that lunges and falls cannot beat one that walks),
or scales it by the share of the episode before the fall (``fall_survival``: the same pressure, but a
population in which every controller falls -- the GA's first generations on the quadruped -- still
tells the longer-lived ones apart, where under ``fall_zero`` they all score 0).

Each robot's draws depend only on its key, so a result does not depend on the batch it is in.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.episode.steering import TOLERANCE
from cpgjax.sim.terrain import Terrain, make_terrain
from cpgjax.sim.variation import Variation

ROUGH_CELL = 0.1        # m: cell of the roughness heightfield
ROUGH_SEED = 20000      # the roughness field is fixed; each robot stands at a random spot of it
TEXTURE_CELL = 0.025    # m: cell of the texture's fine relief (``texture``)
SHIFT = (1.5, 2.0)      # m: half-ranges of the random spot in x and y
PUSH_WINDOW = (0.2, 0.8)  # the shove's time, as a share of the episode: drawn uniformly in this window
PUSH_MAX = 2.0          # m/s: the largest shove accepted
FALL_TILT_MIN = 20.0    # degrees: the smallest tilt accepted as a fall (the walking gaits tilt 15-30 degrees)
TURN_TOLERANCE_MAX = 2.0  # the widest turn_tolerance accepted (2: the score falls to 0 at twice the command's range)


@dataclass(frozen=True)
class Perturbations:
    """Ranges of the robust evaluation (uniform, symmetric about the nominal unless said otherwise)."""

    replicas: int = 4          # episodes per controller and generation (they ride in the same batch)
    lift: float = 0.005        # m: initial height offset
    tilt: float = 0.02         # rad: initial roll and pitch
    roughness: float = 0.0     # m: terrain roughness range (0: the model's terrain as it is; > 0 costs 1.8x)
    friction: float = 0.1      # relative: friction coefficients
    mass: float = 0.05         # relative: each body's mass and inertia
    gain: float = 0.1          # relative: each servo's kp, ki, kd
    jitter: float = 1e-3       # rad: sd of the gene jitter
    bristle: float = 0.0       # decades: the friction bristle's k scaled by 10^U(bristle_from, bristle)
    bristle_from: float = 0.0  # decades: the least stiffening of the bristle (0: the model's own k at the least)
    torque: float = 0.0        # relative: each servo's torque limit
    stiffness: float = 0.0     # relative: the ground's stiffness A (eq. 3.7)
    damping: float = 0.0       # relative: the ground's damping B (eq. 3.7)
    relief: float = 0.0        # share: the rough field's heights scaled by 1 - U(0, relief) per episode
    texture: float = 0.0       # m: with roughness, a fine relief U(0, texture) on 2.5 cm cells added to the field
    push: float = 0.0          # m/s: once per episode every body's velocity changes by U(-push, push) in x and y
    noise: float = 0.0         # sensor noise, in each sensor's scale (sd; closed-loop controllers)
    latency: int = 0           # steps between a closed-loop controller's observation and its action (0 or 1)
    touch: float = 0.0         # m: each touch sensor reads its foot down from a depth U(-x, x), drawn per episode
    command: float = 0.0       # rad/s: range of the commanded turning rate (0: no command, eq. 4.6's score)
    speed: float = 0.0         # m/s: the score credits the speed up to this (0: no cap; with or without command)
    turn_speed: float = 0.0    # m/s: with speed, the cap at a full turn (falling from speed at no turn; 0: none)
    overspeed: float = 0.0     # with speed: each m/s above the cap costs this many m/s of the score
    turn_tolerance: float = TOLERANCE  # with command: the turn error, a share of its range, at which the score is 0
    per_cap: bool = False      # with command and speed: the score is over the episode's cap, up to 1 in any turn
    fall_ends: bool = True     # a robot's fitness stops at a fall (body tilted past 60 degrees)
    fall_zero: bool = False    # a fall forfeits the episode: its fitness is 0 (implies fall_ends)
    fall_survival: bool = False  # a fall scales the episode's fitness by the share of it before the fall
    worst: int = 0             # the score is the mean of the worst this many of the replicas' episodes (0: all)
    fall_tilt: float = 60.0    # degrees: the tilt past which the evaluation counts a fall (the judges keep 60)

    def __post_init__(self) -> None:
        if self.replicas < 1:
            raise ValueError(f"replicas must be >= 1, got {self.replicas}")
        for f in ("lift", "tilt", "roughness", "friction", "mass", "gain", "jitter", "bristle", "bristle_from",
                  "torque", "stiffness", "damping", "relief", "noise", "command", "speed", "turn_speed", "touch",
                  "texture", "push", "overspeed"):
            v = getattr(self, f)
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"perturbation {f} must be a finite number >= 0, got {v}")
        for f in ("friction", "mass", "gain", "torque", "stiffness", "damping"):
            if getattr(self, f) >= 1:
                raise ValueError(f"perturbation {f} is relative and must be < 1, got {getattr(self, f)}")
        if self.bristle_from > self.bristle:
            raise ValueError(f"perturbation bristle_from ({self.bristle_from:g}) is where the bristle's range of "
                             f"decades starts: it must be <= bristle ({self.bristle:g})")
        if self.relief > 1:
            raise ValueError(f"perturbation relief is a share of the roughness and must be <= 1, got {self.relief}")
        if self.texture > 0 and self.roughness == 0:
            raise ValueError("perturbation texture is a fine relief added to the rough field: give roughness too "
                             "(e.g. roughness=0.04,texture=0.002)")
        if self.push > PUSH_MAX:
            raise ValueError(f"perturbation push is the shove's range, in m/s, and must be <= {PUSH_MAX:g}, "
                             f"got {self.push:g}")
        if self.texture > 0.01:
            raise ValueError(f"perturbation texture is the fine relief's range, in m, and must be <= 0.01 (1 cm), "
                             f"got {self.texture:g}")
        if self.touch > 0.01:
            raise ValueError(f"perturbation touch is the touch sensors' threshold, in m, and must be <= 0.01 "
                             f"(1 cm), got {self.touch:g}")
        if self.latency not in (0, 1):
            raise ValueError(f"perturbation latency is 0 or 1 step, got {self.latency}")
        if self.turn_speed > 0 and not (0 < self.turn_speed <= self.speed):
            raise ValueError(f"perturbation turn_speed ({self.turn_speed:g}) is the speed credited at a full turn, "
                             f"the cap falling to it from speed at no turn: give speed too, at least as large "
                             f"(e.g. command=0.4,speed=0.6,turn_speed=0.2)")
        if not (np.isfinite(self.turn_tolerance) and 0 < self.turn_tolerance <= TURN_TOLERANCE_MAX):
            raise ValueError(f"perturbation turn_tolerance is the turn error, as a share of the command's range, at "
                             f"which the steering score reaches 0: above 0 and at most {TURN_TOLERANCE_MAX:g}, "
                             f"got {self.turn_tolerance:g}")
        if self.turn_tolerance != TOLERANCE and self.command == 0:
            raise ValueError(f"perturbation turn_tolerance ({self.turn_tolerance:g}) sets how the steering score "
                             f"falls with the turn error: give command too (e.g. command=0.4,turn_tolerance=1)")
        if self.per_cap and (self.command == 0 or self.speed == 0):
            raise ValueError("perturbation per_cap divides the steering score by the episode's speed cap: give "
                             "command and speed too (e.g. command=0.4,speed=0.5,turn_speed=0.15,per_cap=on)")
        if self.overspeed > 0 and self.speed == 0:
            raise ValueError(f"perturbation overspeed ({self.overspeed:g}) charges the speed above the cap: give "
                             f"speed too (e.g. command=0.3,speed=0.5,turn_speed=0.15,overspeed=1)")
        if not 0 <= self.worst <= self.replicas:
            raise ValueError(f"perturbation worst is how many of the {self.replicas} episodes (replicas) the score "
                             f"is the mean of, the worst ones: 0 (all) to {self.replicas}, got {self.worst}")
        if not (np.isfinite(self.fall_tilt) and FALL_TILT_MIN <= self.fall_tilt <= 60.0):
            raise ValueError(f"perturbation fall_tilt is the tilt counted as a fall, in degrees, from "
                             f"{FALL_TILT_MIN:g} to 60 (the judges' fall), got {self.fall_tilt:g}")
        if self.fall_zero and self.fall_survival:
            raise ValueError("fall_zero and fall_survival exclude each other: a fall forfeits the episode or scales it")

    def to_dict(self) -> dict:
        """The ranges as a dict; the ranges added after the first run files were written are left out while off,
        so that those files' records still equal their ranges (and the runs resume)."""
        d = dataclasses.asdict(self)
        return {k: v for k, v in d.items() if not (k in LATER and v == LATER[k])}

    @staticmethod
    def from_settings(settings: dict | None) -> Perturbations:
        """The ranges of ``--perturb`` settings: a ``preset`` (:data:`PRESETS`) expanded, the other keys over it."""
        s = dict(settings or {})
        name = s.pop("preset", None)
        if name is not None and name not in PRESETS:
            raise ValueError(f"unknown perturbation preset {name!r}; expected one of {', '.join(PRESETS)}")
        return Perturbations(**({**PRESETS[name], **s} if name else s))


#: What each range does, its unit and the values it takes (``--perturb``'s help, :mod:`cpgjax.cli.options`).
MEANING = {
    "replicas": "episodes per controller and generation, each with its own draws (a whole number >= 1)",
    "lift": "the robot starts lifted or lowered by up to this, m",
    "tilt": "the robot starts rolled and pitched by up to this, rad",
    "roughness": "rough ground: heights from 0 to this added to the terrain, m (0: the terrain as it is; "
                 "> 0 makes an episode 1.8x slower)",
    "friction": "the ground's friction scaled by 1 + U(-x, x) (relative, < 1; so are mass, gain, torque, stiffness "
                "and damping)",
    "mass": "each body's mass and inertia scaled by 1 + U(-x, x)",
    "gain": "each servo's PID gains scaled by 1 + U(-x, x)",
    "jitter": "every gene moved by noise of this standard deviation, rad",
    "bristle": "the foot's friction spring made up to 10^x times stiffer, in decades (e.g. 3: a gait must then walk "
               "on any foot from soft to stiff, which is what carries over to MuJoCo)",
    "bristle_from": "where the bristle's range starts, in decades (default 0: from the model's own spring; e.g. 1 with "
                    "bristle=3: every episode's foot 10 to 1000 times stiffer, none as soft as the model's)",
    "torque": "each servo's torque limit scaled by 1 + U(-x, x)",
    "stiffness": "the ground's stiffness scaled by 1 + U(-x, x)",
    "damping": "the ground's damping scaled by 1 + U(-x, x)",
    "relief": "with roughness, or on stairs, a bar or a gap: each episode's ground flattened by a random share up "
              "to this, 0 to 1 (1: anywhere from flat to fully rough, or stairs from none to full height)",
    "texture": "with roughness: a fine relief, heights from 0 to this on 2.5 cm cells, added to the rough field, m "
               "(e.g. 0.002: a foot that skims the ground in its swing catches on it, as on MuJoCo's triangles)",
    "push": "a shove: once per episode, at a time drawn between 0.2 and 0.8 of it, every body's velocity changes by "
            "U(-x, x) m/s in x and y (e.g. 0.2: a gait must recover from a stumble)",
    "noise": "closed-loop controllers only: sensor noise, its standard deviation in each sensor's typical size",
    "latency": "closed-loop controllers only: 0 or 1 step between sensing and acting",
    "touch": "closed-loop controllers reading contact only: each leg's touch sensor reads its foot down from a depth "
             "U(-x, x) drawn per episode, m (e.g. 0.001: a gait cannot live on the millisecond its foot lands)",
    "command": "closed-loop controllers that read the command only: a turning rate drawn up to +-x rad/s for each "
               "half of the episode, the score how well the robot follows it (steering)",
    "speed": "the score credits speed up to this, m/s (0: no cap): with command the steering score, without it "
             "eq. 4.6's (e.g. 0.5: a gait scored by how surely it reaches 0.5 m/s, not by how far past it it goes)",
    "turn_speed": "with speed: the cap falls from speed at no turn to this at a full turn (the episode's mean "
                  "abs(command) over command), m/s: a gait fast on a straight line and slow in a tight turn",
    "overspeed": "with speed: each m/s walked above the cap is taken off the score at this weight (0: "
                 "the cap only credits; e.g. 1 with turn_speed: a gait too fast for a tight turn scores less, "
                 "not the same)",
    "turn_tolerance": "with command: the turn error, as a share of the command's range, at which the steering "
                      "score falls to 0 (default 0.5; e.g. 1: a gait that turns half as fast as told still scores "
                      "half)",
    "per_cap": "with command and speed: when on, each episode's steering score is divided by its speed cap, so "
               "that a tight turn at its low cap counts as much as a straight walk at the full one (each up to 1)",
    "fall_ends": "when on, a fall (the body tilted past 60 degrees) ends the episode's score",
    "fall_tilt": "the tilt counted as a fall in evolution, degrees, 20 to 60 (default 60, the judges' fall; e.g. 40: "
                 "a gait that rocks to 50 degrees and recovers here counts as fallen, a margin for another engine)",
    "fall_zero": "when on, a fall forfeits the episode, it scores 0",
    "fall_survival": "when on, a fall scales the episode's score by the share of it before the fall",
    "worst": "the score is the mean of the worst this many of the replicas' episodes, 0 to replicas (default 0: the "
             "mean of all; e.g. 1: the worst episode, a gait scored by its bad luck rather than its good)",
}

#: The ranges added later, and their value when off (:meth:`Perturbations.to_dict`).
LATER = {"bristle_from": 0.0, "torque": 0.0, "stiffness": 0.0, "damping": 0.0, "relief": 0.0, "noise": 0.0,
         "latency": 0, "command": 0.0, "speed": 0.0, "turn_speed": 0.0, "touch": 0.0, "worst": 0, "texture": 0.0,
         "push": 0.0, "overspeed": 0.0, "fall_tilt": 60.0, "turn_tolerance": TOLERANCE,
         "per_cap": False}

#: Named sets of ranges.  ``domain``: domain randomisation (docs/evolution.md): rough ground from flat to 4 cm at a
#: random spot of the field, ground friction +-30 %, body masses +-10 %, servo gains and torque limits +-20 %, the
#: ground's stiffness and damping +-50 %, the foot's bristle up to 3 decades stiffer, falls scaling the score.
PRESET_MEANING = {"domain": "domain randomisation, every kind of variation at once and wide"}
PRESETS = {
    "domain": {"roughness": 0.04, "relief": 1.0, "friction": 0.3, "mass": 0.1, "gain": 0.2, "torque": 0.2,
               "stiffness": 0.5, "damping": 0.5, "bristle": 3.0, "fall_survival": True},
}


def check_controller(p: Perturbations, family) -> None:
    """Refuse ranges that ``family`` (a :class:`cpgjax.episode.policy.Family`; None: the open-loop CPG) cannot
    feel, rather than ignore them: sensor ``noise`` and ``latency`` need a controller that reads sensors, a
    ``command`` one that reads the command (ValueError naming the key)."""
    for key, what in (("noise", "sensor noise"), ("latency", "a sensor latency")):
        if family is None and getattr(p, key):
            raise ValueError(f"perturbation {key}: the open-loop CPG reads no sensor, so {what} would change "
                             "nothing; it applies to a closed-loop controller (--controller pmtg, docs/closed-loop.md)")
    if p.touch > 0 and (family is None or not {"contact", "stance"} & set(family.inputs)):
        raise ValueError("perturbation touch: the controller must read its touch sensors (--controller "
                         "pmtg:...+contact+... or +stance+, e.g. pmtg:tilt+contact+bias)")
    if p.command > 0 and (family is None or "command" not in family.inputs):
        raise ValueError("perturbation command: the controller must read the command (--controller "
                         "pmtg:...+command+..., e.g. pmtg:tilt+contact+command+steer+bias)")


def roughened(terrain: Terrain, roughness: float, texture: float = 0.0) -> Terrain:
    """``terrain`` plus a fixed field of uniform roughness in [0, roughness] (0.1 m cells); with ``texture`` that
    field sampled on 2.5 cm cells (bilinear, :data:`TEXTURE_CELL`) plus heights uniform in [0, texture] there."""
    if roughness <= 0:
        return terrain
    rough = make_terrain(f"rough:{roughness:g}:{ROUGH_CELL:g}:{ROUGH_SEED}")
    if texture > 0:
        fine = make_terrain(f"rough:{texture:g}:{TEXTURE_CELL:g}:{ROUGH_SEED + 1}")
        ny, nx = fine.heights.shape
        X, Y = np.meshgrid(fine.x0 + fine.dx * np.arange(nx), fine.y0 + fine.dy * np.arange(ny))
        rough = Terrain(f"{rough.spec}+{fine.spec}", rough.height_np(X, Y) + fine.heights,
                        fine.x0, fine.y0, fine.dx, fine.dy)
    if terrain.flat:
        return rough
    ny, nx = rough.heights.shape
    X, Y = np.meshgrid(rough.x0 + rough.dx * np.arange(nx), rough.y0 + rough.dy * np.arange(ny))
    field = Terrain(terrain.spec, terrain.heights, terrain.x0, terrain.y0, terrain.dx, terrain.dy)   # no ledges
    return Terrain(f"{terrain.spec}+{rough.spec}", field.height_np(X, Y) + rough.heights,
                   rough.x0, rough.y0, rough.dx, rough.dy, ledges=terrain.ledges)


def _one(model, p: Perturbations, key: jax.Array, n_genes: int):
    """One robot's draws: its Variation fields and gene offsets.

    Every product is kept apart from the sum that uses it (``optimization_barrier``): XLA may otherwise
    contract ``1 + r u`` into a fused multiply-add in one compiled program and not in another, and a
    last-bit difference is enough to change an episode (a sweep's run must equal the same run alone).
    The gene jitter is uniform with standard deviation ``jitter`` (``jax.random.normal`` evaluates a
    polynomial, with the same hazard).
    """
    ks = jax.random.split(key, 8)
    u = lambda k, shape, r: jax.lax.optimization_barrier(  # noqa: E731
        r * jax.random.uniform(k, shape, jnp.float32, -1.0, 1.0))
    shift = jnp.stack([u(ks[0], (), SHIFT[0]), u(ks[1], (), SHIFT[1])]) if p.roughness > 0 else jnp.zeros(2)
    # the bristle's draw has its own key (folded in), so that adding it left every other draw as it was; so have
    # the later ones (each drawn only when its range is not 0: otherwise the field is None, the model's value)
    if p.bristle_from:
        span = p.bristle - p.bristle_from
        decades = p.bristle_from + 0.5 * span * (1.0 + u(jax.random.fold_in(key, 8), (), 1.0))
    else:
        decades = 0.5 * p.bristle * (1.0 + u(jax.random.fold_in(key, 8), (), 1.0))
    more = {}
    for i, (f, shape) in enumerate((("torque", (model.n_ctrl,)), ("stiffness", ()), ("damping", ()))):
        if getattr(p, f) > 0:
            more[f] = 1.0 + u(jax.random.fold_in(key, 9 + i), shape, getattr(p, f))
    if p.relief > 0 and (p.roughness > 0 or model.terrain.ledges is not None):
        more["relief"] = 1.0 - 0.5 * p.relief * (1.0 + u(jax.random.fold_in(key, 12), (), 1.0))
    if p.push > 0:   # the shove's x and y velocities, then its time as a share of the episode (PUSH_WINDOW)
        kp = jax.random.fold_in(key, PUSH_STREAM)
        a, b = PUSH_WINDOW
        more["push"] = jnp.concatenate([u(kp, (2,), p.push), jnp.zeros(1)])
        more["push_at"] = a + (b - a) * jax.random.uniform(jax.random.fold_in(kp, 1), (), jnp.float32)
    return (Variation(friction=1.0 + u(ks[2], (), p.friction), mass=1.0 + u(ks[3], (model.nb,), p.mass),
                      gain=1.0 + u(ks[4], (model.n_ctrl,), p.gain), shift=shift,
                      lift=u(ks[5], (), p.lift), tilt=u(ks[6], (2,), p.tilt),
                      bristle=jnp.power(10.0, jax.lax.optimization_barrier(decades)), **more),
            u(ks[7], (n_genes,), float(np.sqrt(3.0)) * p.jitter))


NOISE_STREAM = 13   # folded into a robot's key: the key of its sensor noise (the draws above use 0..12)
PUSH_STREAM = 16    # folded into a robot's key: the key of its shove (``push``)


def noise_key(keys: jax.Array) -> jax.Array:
    """[N, 2] uint32: the raw key of each robot's sensor noise, from its episode's key [N]."""
    return jax.vmap(lambda k: jax.random.key_data(jax.random.fold_in(k, NOISE_STREAM)))(keys)


COMMAND_STREAM = 14   # folded into a robot's key: the key of its commanded turning rates


def commands(keys: jax.Array, limit: float) -> jax.Array:
    """[2, N] the commanded turning rates of each robot's two halves of the episode, ``U(-limit, limit)`` rad/s,
    from its episode's key [N] (:data:`COMMAND_STREAM`)."""
    c = jax.vmap(lambda k: jax.random.uniform(jax.random.fold_in(k, COMMAND_STREAM), (2,), jnp.float32,
                                              -1.0, 1.0))(keys)
    return jax.lax.optimization_barrier(limit * c.T)


TOUCH_STREAM = 15   # folded into a robot's key: the key of its touch sensors' thresholds


def touch_thresholds(keys: jax.Array, legs: int, reach: float) -> jax.Array:
    """[N, legs] the depth (m) from which each robot's touch sensors read their foot down, ``U(-reach, reach)``,
    from its episode's key [N] (:data:`TOUCH_STREAM`; :func:`cpgjax.episode.sensors.touch`)."""
    u = jax.vmap(lambda k: jax.random.uniform(jax.random.fold_in(k, TOUCH_STREAM), (legs,), jnp.float32,
                                              -1.0, 1.0))(keys)
    return jax.lax.optimization_barrier(reach * u)


def draw(model, p: Perturbations, keys: jax.Array, n_genes: int) -> tuple[Variation, jax.Array]:
    """Per-robot perturbations from keys [N]: a batch-last :class:`Variation` [..., N] and gene offsets [N, G]."""
    var, offsets = jax.vmap(lambda k: _one(model, p, k, n_genes))(keys)
    return jax.tree.map(lambda a: jnp.moveaxis(a, 0, -1), var), offsets
