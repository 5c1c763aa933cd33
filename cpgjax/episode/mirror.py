"""A mirror-symmetric closed-loop genome (beyond the thesis): the left side does what the right side does, half a
period later, and the policy answers a mirrored state with the mirrored action.

The quadruped is its own mirror image in the plane ``x = x_c`` of its tracked body (forward is +y, x across), and
its trot is symmetric under that mirror and half a period's shift: each left leg does what its right partner did
half a period before.  A closed-loop controller (:mod:`cpgjax.episode.policy`) evolved gene by gene loses the
symmetry, and turns left and right unequally (docs/results/steering.md).  The family's ``mirror`` option
(``--controller pmtg:GROUPS:mirror``) evolves only one half (the first joint of each mirror pair in the file's
order: the quadruped's right legs) and derives the rest, so that whatever a gait learns for one side, and for one
direction of turning, holds for the other:

- **the CPG**: the row of a joint's partner is its own with the k-th harmonic shifted by half a period (``a_k, b_k``
  times ``(-1)^k``; ``c0`` kept), times the pair's sign ``sigma`` (+1 when the mirrored rotation of one joint is the
  positive rotation of the other: its axis is the mirror image of the other's as an axial vector, ``-M a``);
- **the policy** ``u = W obs``: mirrored, each reading becomes its partner's times a sign ``s`` (a joint's angle: its
  partner's times ``sigma``; roll and its rate change sign, pitch and its rate keep it; a foot's contact: its mirror
  foot's; the CPG's phase (sin, cos), half a period on: both negated; the command, a turning rate: negated; the
  command times the phase: kept; its size ``turn``: kept; the bias: kept).  A partner joint's offsets row is then
  its own, read through the mirror, ``W[p(i), j] = sigma_i s_j W[i, m(j)]``, and the frequency's and amplitude's rows
  (one number for the whole robot) are mirror-invariant, ``W[g, j] = s_j W[g, m(j)]``: a reading whose mirror image is
  its own negative (roll, the command) cannot move them, a pair of readings moves them equally.

The genome is the full one's free genes, in the full genome's order (:class:`Mirror`): the quadruped with
``pmtg:tilt+contact+command+steer+bias`` has 72 genes instead of 140.  A `.ctl` file holds the expanded controller
(a plain ``pmtg``; the symmetry is the genome's, not the controller's).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: x -> -x: the mirror across the robot's sagittal plane (forward is +y)
M = np.diag([-1.0, 1.0, 1.0])
TOL = 1e-6    # m, and for unit axes: how close a mirrored joint or foot must come to its partner


class MirrorError(ValueError):
    """A model or controller that a mirror genome cannot describe."""


@dataclass(frozen=True)
class Mirror:
    """How a reduced (mirror) genome fills the full closed-loop genome: ``full = [g, 0][idx] * sign``.

    ``idx`` [G_full] the reduced gene behind each full gene (``n_genes`` where it is 0), ``sign`` [G_full] +1 or -1
    (0 where it is 0); ``rep`` [n_genes] where each reduced gene sits in the full genome (with sign +1).
    """

    idx: np.ndarray
    sign: np.ndarray
    rep: np.ndarray

    @property
    def n_genes(self) -> int:
        return int(self.rep.shape[0])


def _plane(model) -> float:
    return float(model.x0[0, model.track])


def _partners(points: list, x_c: float, what: list[str]) -> np.ndarray:
    """For each point [3] the index of the point at its mirror image across ``x = x_c`` (:class:`MirrorError`
    naming ``what[i]`` when there is none)."""
    P = np.asarray(points, float)
    image = P * np.array([-1.0, 1.0, 1.0]) + np.array([2.0 * x_c, 0.0, 0.0])
    out = np.full(len(P), -1)
    for i, q in enumerate(image):
        hits = np.flatnonzero(np.linalg.norm(P - q, axis=1) < TOL)
        if not len(hits):
            raise MirrorError(f"{what[i]} has no mirror partner across x = {x_c:g}: the model is not left-right "
                              "symmetric")
        out[i] = hits[0]
    return out


def joint_pairs(model) -> tuple[np.ndarray, np.ndarray]:
    """(partner [n_ctrl], sigma [n_ctrl]): each controlled joint's mirror partner (an index among the controlled
    joints) and the sign between their angles; :class:`MirrorError` when a joint has no partner, lies on the plane,
    or its partner's axis is not its mirror image."""
    from cpgjax.sim.rotation import quat_to_mat_np

    desc = model.description
    if desc is None:
        raise MirrorError("a mirror genome needs the model's description (its joints' pivots)")
    x_c = _plane(model)
    piv, axes = [], []
    for j in model.ctrl_joint:
        ia = int(model.j_a[j])
        R = quat_to_mat_np(model.q0[:, ia])
        piv.append(model.x0[:, ia] + R @ (np.asarray(desc.joints[j].pivot_a, float) - model.cm_local[:, ia]))
        axes.append(R @ model.j_axis[:, j])
    names = [model.joint_names[int(j)] for j in model.ctrl_joint]
    partner = _partners(piv, x_c, [f"joint {n!r}" for n in names])
    sigma = np.zeros(len(piv))
    for i, k in enumerate(partner):
        name = names[i]
        if k == i:
            raise MirrorError(f"joint {name!r} lies on the mirror plane x = {x_c:g}; a mirror genome pairs every "
                              "controlled joint with another")
        s = float(axes[k] @ (-M @ axes[i]))
        if abs(abs(s) - 1.0) > TOL:
            raise MirrorError(f"joints {name!r} and {names[k]!r}: the axes are not mirror images of each other")
        sigma[i] = np.sign(s)
    return partner, sigma


def leg_pairs(model) -> np.ndarray:
    """[legs] each leg's mirror partner (`cpgjax.episode.descriptors.legs` order), from its foot's vertices."""
    from cpgjax.episode.descriptors import legs
    from cpgjax.sim.rotation import quat_to_mat_np

    feet = legs(model)[1]
    x_c = _plane(model)
    where = []
    for k in range(feet.shape[0]):
        pts = model.ct_pt[np.nonzero(feet[k])[0]]
        b = model.pt_body[pts]
        R = quat_to_mat_np(model.q0[:, b])
        where.append((model.x0[:, b] + np.einsum("ij...,j...->i...", R, model.pt_local[:, pts])).mean(1))
    return _partners(where, x_c, [f"leg {k}" for k in range(len(where))])


def input_map(model, family) -> tuple[np.ndarray, np.ndarray]:
    """(m [n_in], s [n_in]): the reading each reading becomes under the mirror and the half-period shift, and its
    sign (see the module docstring)."""
    m, s, at = [], [], 0
    for g, n in family.input_sizes(model):
        if g == "angles":
            partner, sigma = joint_pairs(model)
            m += list(at + partner)
            s += list(sigma)
        elif g in ("contact", "stance"):
            m += list(at + leg_pairs(model))
            s += [1.0] * n
        else:
            m += [at + k for k in range(n)]
            s += {"tilt": [-1.0, 1.0], "rates": [-1.0, 1.0], "phase": [-1.0, -1.0], "command": [-1.0],
                  "steer": [1.0, 1.0], "turn": [1.0], "bias": [1.0]}[g]
        at += n
    return np.asarray(m), np.asarray(s)


_CACHE: dict = {}


def _mirror(model, family) -> Mirror:
    partner, sigma = joint_pairs(model)
    m, s = input_map(model, family)
    n_ctrl, n_coeff, n_in = model.n_ctrl, model.n_coeff, family.n_in(model)
    harm = np.array([1.0] + [(-1.0) ** k for k in range(1, model.episode.harmonics + 1) for _ in (0, 1)])
    cpg = np.zeros((n_ctrl, n_coeff, 2))          # (source full index, sign) of each CPG gene
    W = np.zeros((family.n_out(model), n_in, 2))  # the same for each weight
    base = n_ctrl * n_coeff
    for i in range(n_ctrl):
        for c in range(n_coeff):
            if i < partner[i]:
                cpg[i, c] = (i * n_coeff + c, 1.0)
            else:
                cpg[i, c] = (partner[i] * n_coeff + c, sigma[i] * harm[c])
        for j in range(n_in):
            if i < partner[i]:
                W[i, j] = (base + i * n_in + j, 1.0)
            else:
                W[i, j] = (base + partner[i] * n_in + m[j], sigma[i] * s[j])
    for g in range(n_ctrl, family.n_out(model)):  # frequency, amplitude: mirror-invariant rows
        for j in range(n_in):
            if m[j] == j:
                W[g, j] = (base + g * n_in + j, 1.0) if s[j] > 0 else (-1, 0.0)
            elif j < m[j]:
                W[g, j] = (base + g * n_in + j, 1.0)
            else:
                W[g, j] = (base + g * n_in + m[j], s[j])
    src = np.concatenate([cpg.reshape(-1, 2), W.reshape(-1, 2)])
    free = np.flatnonzero(src[:, 0] == np.arange(len(src)))          # the genes that are their own source
    number = np.full(len(src) + 1, -1)
    number[free] = np.arange(len(free))
    source = src[:, 0].astype(int)
    idx = np.where(source >= 0, number[source], len(free))
    return Mirror(idx=idx.astype(np.int32), sign=src[:, 1].astype(np.float32), rep=free.astype(np.int32))


def mirror(model, family) -> Mirror:
    """The :class:`Mirror` of ``family`` (a closed-loop family with ``mirror``) on ``model`` (made once per model
    and family)."""
    key = (model, family)            # the model's structure (sim.fingerprint)
    if key not in _CACHE:
        _CACHE[key] = _mirror(model, family)
    return _CACHE[key]


def expand(mir: Mirror, genomes):
    """Reduced genomes [N, n_genes] to full ones [N, G_full] (numpy or JAX, the same kind out)."""
    import jax
    import jax.numpy as jnp

    xp = jnp if isinstance(genomes, jax.Array) else np
    g = xp.concatenate([genomes, xp.zeros(genomes.shape[:-1] + (1,), genomes.dtype)], -1)
    return g[..., mir.idx] * xp.asarray(mir.sign, genomes.dtype)


def reduce(mir: Mirror, full: np.ndarray, what: str = "the controller") -> np.ndarray:
    """A full genome [..., G_full] as a reduced one; :class:`MirrorError` (naming ``what``) when it is not
    mirror-symmetric (its expansion differs from it by more than 1e-6)."""
    full = np.asarray(full, np.float32)
    g = full[..., mir.rep]
    err = np.abs(expand(mir, g) - full)
    if err.max(initial=0.0) > 1e-6:
        k = int(np.argmax(err.reshape(-1)) % full.shape[-1])
        raise MirrorError(f"{what} is not mirror-symmetric (gene {k} differs from its mirror image's by "
                          f"{float(err.max()):.3g}); a mirror genome needs the left side to do what the right does "
                          "half a period later (the hand-written trot does)")
    return g
