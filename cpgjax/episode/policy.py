"""A closed-loop controller: the thesis's CPG modulated by a feedback policy (beyond the thesis; its Ch. 5.4.2, 7).

Policies Modulating Trajectory Generators (Iscen et al., CoRL 2018): the thesis's CPG (Ch. 2.2.1,
:mod:`cpgjax.episode.cpg`) is the trajectory generator, and a linear policy reads what the robot senses
(:mod:`cpgjax.episode.sensors`) and writes, every integration step,

- ``offsets`` [n_ctrl]: added to the CPG's target angles (rad);
- ``frequency`` m_f: the CPG runs at ``f0 (1 + m_f)``: its phase is ``2 pi f0 (t + d)`` with ``d' = m_f``
  integrated in the episode's scan (``d(0) = 0``);
- ``amplitude`` m_a: the CPG's oscillation about its mean ``c0`` is scaled by ``1 + m_a``.

So the servo target of joint i is ``q*_i = c0_i + (1 + m_a) sum_k (a_ik sin(k w tau) + b_ik cos(k w tau)) + o_i``,
``w = 2 pi f0``, ``tau = t + d``, and its rate the CPG's at ``tau`` times ``(1 + m_f)(1 + m_a)``.  The action is
``u = W obs`` (``W`` [outputs, inputs]), clipped to :data:`LIMITS`.  With ``W = 0`` every modulation is exactly 0
and the targets are the open-loop CPG's bit for bit: the phase is the CPG's ``sin(k w t)``, ``cos(k w t)`` turned
by the angle ``k w d`` (``cos 0 = 1``, ``sin 0 = 0``), not a sine of a new argument.

**The genome** is the CPG's coefficients (as for the open-loop CPG, row by row) followed by the policy's genes
``g`` [outputs, inputs] row by row, all in the GA's box (:data:`cpgjax.episode.cpg.GENE_BOX`: [-0.8, 0.8]).
A weight is its gene scaled, ``W = g * OUT[o] / SCALES[i]`` (:func:`weight_scale`): a gene of 0.8 on an input of
its typical size (:data:`cpgjax.episode.sensors.SCALES`) moves an output by 0.8 of the output's scale
(:data:`OUTPUT_SCALES`: 0.5 rad of offset, 1.0 of frequency, 0.5 of amplitude).  The open-loop CPG's genes
followed by zeros is the closed-loop controller that does what the CPG does.

**Latency**: with ``latency`` the action of a step uses the observation of the step before (the first step uses
the initial state's).  **Noise**: per robot and step, uniform, drawn from the robot's key
(:func:`cpgjax.episode.sensors.noise`).  Both are perturbations of the robust evaluation
(:class:`cpgjax.episode.perturb.Perturbations`: ``latency``, ``noise``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from cpgjax.episode import sensors

FAMILIES = ("cpg", "pmtg")   # the open-loop CPG (the thesis's), and the CPG modulated by a linear policy
OUTPUTS = ("offsets", "frequency", "amplitude")
OUTPUT_SCALES = {"offsets": 0.5, "frequency": 1.0, "amplitude": 0.5}
#: Each output is clipped to this range: offsets (rad), frequency (f0 from 0.1 to 3 times), amplitude (0 to 2 times).
LIMITS = {"offsets": (-0.8, 0.8), "frequency": (-0.9, 2.0), "amplitude": (-1.0, 1.0)}
CONTROLLER_SYNTAX = "cpg | pmtg[:GROUP+GROUP...][:mirror]"


@dataclass(frozen=True)
class Family:
    """A closed-loop controller family: which sensor groups its policy reads (:data:`sensors.GROUPS` order)."""

    name: str = "pmtg"
    inputs: tuple[str, ...] = sensors.DEFAULT_GROUPS
    outputs: tuple[str, ...] = OUTPUTS
    mirror: bool = False     # the genome mirror-symmetric (:mod:`cpgjax.episode.mirror`), not the controller

    def __post_init__(self) -> None:
        if self.name != "pmtg":
            raise ValueError(f"unknown controller family {self.name!r}; expected one of {', '.join(FAMILIES)}")
        bad = [g for g in self.inputs if g not in sensors.GROUPS]
        if bad or not self.inputs or len(set(self.inputs)) != len(self.inputs):
            raise ValueError(f"a policy's inputs are distinct groups of {', '.join(sensors.GROUPS)}; got "
                             f"{'+'.join(self.inputs) or 'none'}")
        if tuple(self.outputs) != OUTPUTS:
            raise ValueError(f"a pmtg policy's outputs are {', '.join(OUTPUTS)}; got {', '.join(self.outputs)}")
        object.__setattr__(self, "inputs", tuple(g for g in sensors.GROUPS if g in self.inputs))

    @property
    def spec(self) -> str:
        """The command-line text (``pmtg``, or ``pmtg:tilt+contact+bias`` when not the default groups; ``:mirror``
        after it for a mirror-symmetric genome, ``pmtg:mirror`` with the default groups)."""
        text = self.name if self.inputs == sensors.DEFAULT_GROUPS else f"{self.name}:{'+'.join(self.inputs)}"
        return text + (":mirror" if self.mirror else "")

    def input_sizes(self, model) -> list[tuple[str, int]]:
        n = sensors.sizes(model)
        return [(g, n[g]) for g in self.inputs]

    def output_sizes(self, model) -> list[tuple[str, int]]:
        return [("offsets", model.n_ctrl), ("frequency", 1), ("amplitude", 1)]

    def n_in(self, model) -> int:
        return sum(n for _, n in self.input_sizes(model))

    def n_out(self, model) -> int:
        return sum(n for _, n in self.output_sizes(model))

    def n_weights(self, model) -> int:
        return self.n_in(model) * self.n_out(model)

    def n_genes(self, model) -> int:
        """The genome's length: the CPG's coefficients and the policy's genes (with ``mirror``, the free ones)."""
        if self.mirror:
            from cpgjax.episode.mirror import mirror

            return mirror(model, self).n_genes
        return model.n_genes + self.n_weights(model)

    def gene_groups(self, model) -> np.ndarray:
        """[n_genes] the group of each gene in this family's genome: ``cpg`` for the CPG's coefficients, else the
        sensor group its weight reads (with ``mirror``, the group of the free gene's place in the full genome)."""
        cols = np.concatenate([np.full(n, g, dtype=object) for g, n in self.input_sizes(model)])
        full = np.concatenate([np.full(model.n_genes, "cpg", dtype=object), np.tile(cols, self.n_out(model))])
        if self.mirror:
            from cpgjax.episode.mirror import mirror

            full = full[mirror(model, self).rep]
        return full.astype(str)

    @property
    def plain(self) -> Family:
        """The same family without ``mirror``: the controller a genome of this family is."""
        return Family(self.name, self.inputs, self.outputs)

    def to_dict(self) -> dict:
        return {"name": self.name, "inputs": list(self.inputs), "outputs": list(self.outputs)} | (
            {"mirror": True} if self.mirror else {})


def parse_controller(text: str | None) -> Family | None:
    """``--controller`` text to a :class:`Family`; ``None`` (or ``cpg``) is the thesis's open-loop CPG."""
    if text is None:
        return None
    name, sep, rest = str(text).strip().partition(":")
    name = name.lower()
    if name == "cpg" and not rest:
        return None
    if name not in FAMILIES:
        raise ValueError(f"unknown controller {text!r}; expected {CONTROLLER_SYNTAX}")
    if name == "cpg":
        raise ValueError(f"controller {text!r}: the open-loop CPG takes no inputs; expected {CONTROLLER_SYNTAX}")
    if sep and not rest.partition(":")[0].strip():             # pmtg: or pmtg::mirror: an empty list of groups
        raise ValueError(f"controller {text!r}: an empty list of sensor groups; name them (e.g. "
                         f"pmtg:tilt+contact+bias), or leave the list out for the default ones (pmtg, pmtg:mirror)")
    rest, _, option = rest.partition(":")
    if not option and rest.strip().lower() == "mirror":          # pmtg:mirror: the default groups, mirrored
        rest, option = "", "mirror"
    if option.strip().lower() not in ("", "mirror"):
        raise ValueError(f"controller {text!r}: expected {CONTROLLER_SYNTAX}")
    groups = tuple(g.strip().lower() for g in rest.split("+")) if rest else sensors.DEFAULT_GROUPS
    return Family(name, groups, mirror=option.strip().lower() == "mirror")


def family_from_meta(meta: dict) -> Family | None:
    """The family a run recorded (its meta's ``controller``), ``None`` for the open-loop CPG (and older runs)."""
    return parse_controller(meta.get("controller") or None)


def weight_scale(family: Family, model) -> np.ndarray:
    """[outputs, inputs] float32: the weight of a gene of 1 (``OUT[o] / SCALES[i]``, see the module docstring)."""
    out = np.concatenate([np.full(n, OUTPUT_SCALES[g]) for g, n in family.output_sizes(model)])
    inp = np.concatenate([np.full(n, sensors.SCALES[g]) for g, n in family.input_sizes(model)])
    return (out[:, None] / inp[None, :]).astype(np.float32)


@jax.tree_util.register_pytree_node_class
class ClosedLoop:
    """A batch of closed-loop controllers (a pytree whose leaves share their leading or trailing batch axis).

    ``coeffs`` [..., n_ctrl, 2K+1] the CPG's; ``weights`` [..., outputs, inputs] the policy's (the weights, not the
    genes: :func:`from_genomes`); ``command`` [...] each robot's commanded turning rate (rad/s), constant; ``key``
    [..., 2] uint32 or None: the raw key of each robot's sensor noise; ``steer`` None or a source of the command
    computed in the episode's scan instead (:class:`cpgjax.episode.steering.Schedule` or ``Course``, its arrays with
    the same robot axis); ``touch`` [..., legs] or None: the depth (m) at which each leg's touch sensor reads its
    foot down (None: 0, the contact law's own test; :func:`cpgjax.episode.sensors.touch`).  ``family`` is static
    (the pytree's aux data).
    """

    def __init__(self, family: Family, coeffs, weights, command=None, key=None, steer=None, touch=None):
        self.family, self.coeffs, self.weights, self.command, self.key = family, coeffs, weights, command, key
        self.steer, self.touch = steer, touch

    def tree_flatten(self):
        return (self.coeffs, self.weights, self.command, self.key, self.steer, self.touch), self.family

    @classmethod
    def tree_unflatten(cls, family, leaves):
        return cls(family, *leaves)

    def replace(self, **kw) -> ClosedLoop:
        family = kw.pop("family", self.family)
        d = {"coeffs": self.coeffs, "weights": self.weights, "command": self.command, "key": self.key,
             "steer": self.steer, "touch": self.touch} | kw
        return ClosedLoop(family, **d)

    def __len__(self) -> int:          # robots first: the number of controllers
        return int(self.coeffs.shape[0])

    def __getitem__(self, idx) -> ClosedLoop:   # robots first: a slice of the batch
        return jax.tree.map(lambda a: a[idx], self)

    def __repr__(self) -> str:
        return f"ClosedLoop({self.family.spec}, coeffs {getattr(self.coeffs, 'shape', '?')})"


def is_closed(controller: Any) -> bool:
    return isinstance(controller, ClosedLoop)


def batch_size(controller: Any) -> int:
    """The number of controllers N of a batch given robots first (``[N, ...]`` arrays or a :class:`ClosedLoop`)."""
    c = controller.coeffs if is_closed(controller) else controller
    return int(c.shape[0])


def from_genomes(family: Family | None, model, genomes, command=None, key=None, steer=None, touch=None):
    """Genomes [N, G] to controllers: coefficients [N, n_ctrl, 2K+1] (open loop) or a :class:`ClosedLoop` [N]
    (``command``, ``key``, ``steer``, ``touch``: its fields of those names).

    Traceable (numpy or JAX in, the same kind out).  The weights are the genes scaled (:func:`weight_scale`).
    """
    xp = jnp if isinstance(genomes, jax.Array) else np
    g = genomes
    n = g.shape[0]
    if family is None:
        if g.shape[1] != model.n_genes:
            raise ValueError(f"a CPG genome has {model.n_genes} genes, got {g.shape[1]}")
        return g[:, : model.n_genes].reshape(n, model.n_ctrl, model.n_coeff)
    if g.shape[1] != family.n_genes(model):
        what = "free genes of a mirror-symmetric one" if family.mirror else \
            f"{model.n_genes} of the CPG, {family.n_weights(model)} of the policy"
        raise ValueError(f"a {family.spec} genome of this model has {family.n_genes(model)} genes ({what}), "
                         f"got {g.shape[1]}")
    if family.mirror:
        from cpgjax.episode.mirror import expand, mirror

        g, family = expand(mirror(model, family), g), family.plain
    coeffs = g[:, : model.n_genes].reshape(n, model.n_ctrl, model.n_coeff)
    w = g[:, model.n_genes:].reshape(n, family.n_out(model), family.n_in(model)) * weight_scale(family, model)[None]
    if command is None:
        command = xp.zeros((n,), g.dtype)
    return ClosedLoop(family, coeffs, w, command, key, steer, touch)


def widen(controller: ClosedLoop, family: Family, model) -> ClosedLoop:
    """``controller`` (one robot) as a controller of ``family``, whose policy reads every group it reads and more:
    the weights of the groups it does not read are 0, so it acts as before whatever they read (a fast gait made the
    start of one that learns to read the command).  ValueError naming the groups when ``family`` lacks one."""
    have = dict(controller.family.input_sizes(model))
    missing = [g for g in have if g not in family.inputs]
    if missing:
        raise ValueError(f"a policy reading {'+'.join(controller.family.inputs)} cannot be read as "
                         f"{family.plain.spec}: it lacks {', '.join(missing)}")
    w = np.asarray(controller.weights, np.float32)
    cols, at = {}, 0
    for g, n in controller.family.input_sizes(model):
        cols[g], at = w[:, at:at + n], at + n
    wide = np.concatenate([cols.get(g, np.zeros((w.shape[0], n), np.float32)) for g, n in family.input_sizes(model)],
                          axis=1)
    return controller.replace(family=family.plain, weights=wide)


def to_genome(controller: ClosedLoop, model, family: Family | None = None) -> np.ndarray:
    """[G] the genome of one closed-loop controller (its weights divided by their scale) in ``family``'s layout
    (default the controller's; a ``mirror`` family's when the controller is mirror-symmetric, else
    :class:`~cpgjax.episode.mirror.MirrorError`)."""
    w = np.asarray(controller.weights, np.float32) / weight_scale(controller.family.plain, model)
    full = np.concatenate([np.asarray(controller.coeffs, np.float32).reshape(-1), w.reshape(-1)])
    return _in_layout(full, family or controller.family, model, "the controller")


def base_genome(family: Family | None, model, cpg_genome: np.ndarray, symmetrize: bool = False) -> np.ndarray:
    """The closed-loop start: the CPG's start genome and a policy of zeros (it does what the CPG does).  For a
    ``mirror`` family the CPG must be mirror-symmetric (:class:`~cpgjax.episode.mirror.MirrorError`), or with
    ``symmetrize`` its right side is kept and the left side made its mirror image."""
    if family is None:
        return cpg_genome
    full = np.concatenate([np.asarray(cpg_genome, float), np.zeros(family.plain.n_weights(model))])
    return _in_layout(full, family, model, "the starting CPG", symmetrize)


def _in_layout(full: np.ndarray, family: Family, model, what: str, symmetrize: bool = False) -> np.ndarray:
    """A full closed-loop genome as ``family``'s (reduced for a ``mirror`` family)."""
    if not family.mirror:
        return full
    from cpgjax.episode.mirror import mirror, reduce

    mir = mirror(model, family)
    return (full[mir.rep] if symmetrize else reduce(mir, full, what)).astype(full.dtype)


def phase_basis(t, d, harmonics: int, f0: float):
    """The CPG's basis at phase time ``t + d`` (``t`` [] the simulated time, ``d`` [B] the phase offset): values and
    derivatives [2K+1, B], as :func:`cpgjax.episode.cpg.basis` at ``t`` turned by the angles ``k w d``.

    Turning ``(sin kwt, cos kwt)`` by ``kwd`` rather than evaluating ``sin(kw(t + d))`` keeps ``d = 0`` exact: the
    open-loop CPG's values, bit for bit.
    """
    from cpgjax.episode.cpg import basis

    b, db = basis(t, harmonics, f0)
    vals, ders = [jnp.broadcast_to(b[0], d.shape)], [jnp.broadcast_to(db[0], d.shape)]
    for k in range(1, harmonics + 1):
        a = (2 * np.pi * k * f0) * d
        c, s = jnp.cos(a), jnp.sin(a)
        si, ci, dsi, dci = b[2 * k - 1], b[2 * k], db[2 * k - 1], db[2 * k]
        vals += [si * c + ci * s, ci * c - si * s]
        ders += [dsi * c + dci * s, dci * c - dsi * s]
    return jnp.stack(vals), jnp.stack(ders)


def act(family: Family, model, weights, obs):
    """The policy's action: ``(offsets [n_ctrl, B], m_f [B], m_a [B])`` from ``weights`` [out, in, B] and the
    observation [in, B], each clipped to :data:`LIMITS`."""
    # a sum written out term by term in a fixed order, not a dot nor a reduce: the order of a reduce is the compiler's
    # (with XLA's YNNPACK fusions on, which cpgjax._xla turns off, every robot of a chunk of 16 differed from itself
    # in a chunk of 32 within 0.2 s)
    u = weights[:, 0] * obs[0]
    for i in range(1, obs.shape[0]):
        u = u + weights[:, i] * obs[i]
    n = model.n_ctrl
    off = jnp.clip(u[:n], *LIMITS["offsets"])
    return off, jnp.clip(u[n], *LIMITS["frequency"]), jnp.clip(u[n + 1], *LIMITS["amplitude"])


def modulated_targets(coeffs, b, db, off, m_f, m_a):
    """Servo targets and rates [n_ctrl, B] of the CPG ``coeffs`` [n_ctrl, 2K+1, B] at its basis ``b, db``
    [2K+1, B] (:func:`phase_basis`), modulated by the action (see the module docstring)."""
    tgt = (b[None] * coeffs).sum(1)
    rate = (db[None] * coeffs).sum(1)
    q = tgt + m_a * (tgt - coeffs[:, 0]) + off
    return q, rate * ((1.0 + m_f) * (1.0 + m_a))


def from_table(table, model, path: str = "<string>") -> Family:
    """The :class:`Family` of a `.ctl` file's policy (:class:`cpgjax.io.ctl.PolicyTable`), checked against
    ``model``: ``path:line: what is wrong`` (:class:`~cpgjax.sim.description.DescriptionError`) otherwise."""
    from cpgjax.sim.description import DescriptionError

    try:
        fam = Family(table.name, tuple(g for g, _ in table.inputs), tuple(g for g, _ in table.outputs))
    except ValueError as e:
        raise DescriptionError(path, table.line, str(e)) from None
    if tuple(g for g, _ in table.inputs) != fam.inputs:
        raise DescriptionError(path, table.line, f"the policy's inputs must come in the order {', '.join(fam.inputs)}")
    for what, got, want in (("Inputs", table.inputs, fam.input_sizes(model)),
                            ("Outputs", table.outputs, fam.output_sizes(model))):
        if tuple(got) != tuple(want):
            raise DescriptionError(path, table.line, f"{what} {' '.join(f'{g} {n}' for g, n in got)} do not fit the "
                                                     f"model: expected {' '.join(f'{g} {n}' for g, n in want)}")
    return fam


def from_control(control, model):
    """A `.ctl` file's controller for ``model``: coefficients [n_ctrl, 2K+1] (open loop) or a one-robot
    :class:`ClosedLoop` (no robot axis), its weights float32 as written."""
    c = np.asarray(control.coeffs, np.float32)
    if control.policy is None:
        return c
    fam = from_table(control.policy, model, control.path)
    return ClosedLoop(fam, c, np.asarray(control.policy.weights, np.float32), np.zeros((), np.float32))


def table_fields(controller: ClosedLoop, model) -> dict:
    """The fields of the `.ctl` file's policy table of one closed-loop controller (``cpgjax.io.ctl.PolicyTable``)."""
    fam = controller.family
    return {"name": fam.name, "inputs": tuple(fam.input_sizes(model)), "outputs": tuple(fam.output_sizes(model)),
            "weights": np.asarray(controller.weights, np.float64)}


def stack(controllers: list, model):
    """One batch (robots first) of one-robot controllers: coefficients [N, n_ctrl, 2K+1] when every one is the
    open-loop CPG, else a :class:`ClosedLoop` of N in which the open-loop ones have a policy of zeros (which does
    what their CPG does, bit for bit).  Controllers of two closed-loop families cannot share a batch."""
    families = {c.family for c in controllers if is_closed(c)}
    if not families:
        return np.asarray([np.asarray(c, np.float32) for c in controllers])
    if len(families) > 1:
        raise ValueError(f"controllers of {len(families)} closed-loop families "
                         f"({', '.join(sorted(f.spec for f in families))}): one family at a time")
    fam = families.pop()
    shape = (fam.n_out(model), fam.n_in(model))
    coeffs = np.asarray([np.asarray(c.coeffs if is_closed(c) else c, np.float32) for c in controllers])
    weights = np.asarray([np.asarray(c.weights, np.float32) if is_closed(c) else np.zeros(shape, np.float32)
                          for c in controllers])
    return ClosedLoop(fam, coeffs, weights, np.zeros(len(controllers), np.float32))
