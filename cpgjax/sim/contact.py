"""Ground contact at the contact vertices (eq. 3.7, Appendix B), solved implicitly on the whole step.

Normal reaction ``f_r = A d - B v_n`` for a vertex at depth ``d`` below the terrain (A = 1e5 kg/s^2,
B = 1e3 kg/s in the thesis), never pulling.  Friction (Appendix B's static and dynamic branches) is a
regularised Coulomb law with a soft bristle: ``f_t = -k_t z - b_t v_t`` while within ``mu_s f_r``
(``z``: the vertex's tangential displacement since it stuck); beyond it the vertex slides with
``mu_d f_r`` against its motion and the bristle's anchor trails it.

Why this and not a stick-slip spring (docs/simulator.md has the measurements): with the thesis's
stiff stick-slip anchor, a walking robot's score was chaotic (gene jitter of 1e-6 moved the trot's
fitness by sd 0.009; MuJoCo, 0.0003), because a foot's friction and damping were integrated against
the inertia of its own light link only.  Here every other force on the bodies (pivot springs,
servos, gravity) is applied first; each touching vertex's end-of-step velocity ``v*`` is predicted
from its body's accelerations, so the push of the whole robot through its joints is in it; and the
contact force is solved implicitly against that prediction with the vertex's own inverse-mass
matrix ``K = I/m + [r]x^T I^-1 [r]x`` (static in the body frame, :func:`contact_inverse_mass`; shared
among the body's touching vertices): the normal damper and the friction then act in full whatever
the step.  The resting penetration stays exactly ``m g / (A contacts)``: the force carried over from
the previous step is predicted with the translational inverse mass (which the body's touching
vertices share exactly), its change with the full directional one (see :func:`contact_forces`).
"""

from __future__ import annotations

import jax.numpy as jnp
import numpy as np

from cpgjax.sim.ledges import riser_exit
from cpgjax.sim.rotation import cross, dot, matTvec
from cpgjax.sim.terrain import height_and_normal


def contact_body_ranges(model) -> list[tuple[int, int, int]]:
    """``(body, lo, hi)`` for each body with contacts: contacts ``lo:hi`` belong to it (contiguous)."""
    cb = model.pt_body[model.ct_pt]
    out = []
    for b in range(model.nb):
        idx = np.nonzero(cb == b)[0]
        if len(idx):
            assert (np.diff(idx) == 1).all(), "contacts are sorted by body (sim.model)"
            out.append((b, int(idx[0]), int(idx[-1]) + 1))
    return out


def contact_inverse_mass(model) -> np.ndarray:
    """[3, 3, nc] each contact vertex's inverse-mass matrix in its body's frame (zero on a fixed body).

    ``K_b = I/m + [r]x^T I^-1 [r]x`` (r: the vertex from the CM): a force f at the vertex changes its
    velocity by ``dt R K_b R^T f``.
    """
    cb = model.pt_body[model.ct_pt]
    out = np.zeros((3, 3, len(cb)))
    for k, b in enumerate(cb):
        if model.fixed[b]:
            continue
        r = model.pt_local[:, model.ct_pt[k]]
        X = np.array([[0.0, -r[2], r[1]], [r[2], 0.0, -r[0]], [-r[1], r[0], 0.0]])
        out[:, :, k] = np.eye(3) / model.mass[b] + X.T @ model.inv_inertia[:, :, b] @ X
    return out


def _quad(K, u, v):
    """``u^T K v`` for a static symmetric K [3, 3, nc] and u, v [3, nc, B].

    K is known when the model is built: the terms of entries that are zero for every vertex (a foot
    on its link's axis has a diagonal K) are left out, and the symmetric pairs are summed once.
    """
    out = None
    for i in range(3):
        for j in range(i, 3):
            if not np.any(K[i, j]):
                continue
            uv = u[i] * v[j] if (i == j or u is v) else u[i] * v[j] + u[j] * v[i]
            term = K[i, j][:, None] * uv
            if i != j and u is v:
                term = 2.0 * term
            out = term if out is None else out + term
    return out if out is not None else jnp.zeros_like(u[0])


class _Frame:
    """The terrain's contact frame (normal n, tangents t1, t2) under the vertices, as component maps.

    On flat ground the frame is the world's (t1, t2, n) = (x, y, z): components are slices and no
    multiplication by the constant 0s and 1s is emitted (XLA does not fold ``0 * x`` for floats).
    """

    def __init__(self, n=None, t1=None, t2=None):
        self.n, self.t1, self.t2 = n, t1, t2

    def comp(self, v):
        """(v.n, v.t1, v.t2) of a world vector [3, ...]."""
        if self.n is None:
            return v[2], v[0], v[1]
        return dot(v, self.n), dot(v, self.t1), dot(v, self.t2)

    def world(self, fn, f1, f2):
        """The world vector fn n + f1 t1 + f2 t2."""
        if self.n is None:
            return jnp.stack([f1, f2, fn])
        return fn * self.n + f1 * self.t1 + f2 * self.t2

    def in_body(self, Rc):
        """n, t1, t2 in the vertices' body frames (R^T n, ...) [3, nc, B] each."""
        if self.n is None:
            return Rc[2], Rc[0], Rc[1]
        return matTvec(Rc, self.n), matTvec(Rc, self.t1), matTvec(Rc, self.t2)


def contact_frame(model, cp, var):
    """Depth [nc, B] and the :class:`_Frame` of the terrain under the contact vertices at ``cp`` [3, nc, B]."""
    if model.terrain.flat:  # fast path: z_g = 0, n = (0, 0, 1), no lookup
        return -cp[2], _Frame()
    zg, n = terrain_under(model, cp[0], cp[1], var)
    if model.terrain.ledges is not None:
        return _ledge_frame(model, cp, zg, n, var)
    n = jnp.stack(n)
    inv = 1.0 / jnp.sqrt(n[0] ** 2 + n[2] ** 2)
    t1 = jnp.stack([n[2] * inv, jnp.zeros_like(zg), -n[0] * inv])
    return (zg - cp[2]) * n[2], _Frame(n, t1, cross(n, t1))


def _ledge_frame(model, cp, zg, n, var):
    """:func:`contact_frame` on a ground with ledges (`sim.ledges`): a vertex under a tread leaves by the nearer
    of the tread (depth along the surface's normal, as on a heightfield) and a riser beside it (depth along y,
    the normal horizontal).  The tangent t1 is x made orthogonal to the normal (x itself on a riser)."""
    sy = 0.0 if var is None else var.shift[1]
    scale = 1.0 if var is None or var.relief is None else var.relief
    up = (zg - cp[2]) * n[2]
    side, sign = riser_exit(model.terrain.ledges, cp[1] + sy, cp[2], zg, scale)
    riser = (up > 0) & (side < up)
    zero = jnp.zeros_like(up)
    n = jnp.stack([jnp.where(riser, zero, n[0]), jnp.where(riser, sign, n[1]), jnp.where(riser, zero, n[2])])
    t1 = jnp.stack([1.0 - n[0] * n[0], -n[0] * n[1], -n[0] * n[2]])
    t1 = t1 / jnp.sqrt(jnp.sum(t1 * t1, 0))
    return jnp.where(riser, side, up), _Frame(n, t1, cross(n, t1))


def terrain_under(model, x, y, var=None):
    """Height and unit normal (3-tuple) of the terrain under the points ``(x, y)`` of each robot: the model's terrain
    looked up where a :class:`~cpgjax.sim.variation.Variation` places the robot (its ``shift``), its heights and
    slopes scaled by the variation's ``relief`` when it has one."""
    sx, sy = (0.0, 0.0) if var is None else (var.shift[0], var.shift[1])
    zg, n = height_and_normal(model.terrain, x + sx, y + sy)
    if var is None or var.relief is None:
        return zg, n
    s = var.relief                              # z = s h: the gradient scales by s, n ~ (s n_x, s n_y, n_z)
    nx, ny, nz = s * n[0], s * n[1], n[2]
    inv = 1.0 / jnp.sqrt(nx * nx + ny * ny + nz * nz)
    return s * zg, (nx * inv, ny * inv, nz * inv)


def contact_forces(model, R, r, p, pv, a, alpha, anchor, f_prev, var=None, keep=None):
    """Contact forces [3, nc, B], depths [nc, B], new anchors [3, nc, B] and normal forces [nc, B].

    ``a``, ``alpha`` [3, nb, B]: the bodies' accelerations under every force but the contacts;
    ``f_prev`` [nc, B]: each vertex's normal force of the previous step; ``var``: an optional
    per-robot :class:`~cpgjax.sim.variation.Variation` (friction and mass scales, terrain shift).
    ``keep(tree)``: computes a tree once into memory (:func:`cpgjax.sim.springs.step.step` passes one on uneven
    terrain, where the contact frame under each vertex is looked up: see there); ``None``: nothing kept.

    Normal (implicit damper on the predicted velocity ``v' = v* + dt k_n f``, the spring explicit):
    ``f = A d - B v'``, with the part of ``f`` carried over from the previous step predicted at the
    translational inverse mass ``k_t = share/m`` and its change at the full ``k_n = share n^T K n``:
    ``v' = v* + dt (k_t f_prev + k_n (f - f_prev))``.  At rest ``v' = 0`` and ``f = f_prev``, so
    ``f = A d`` exactly; in motion the damper acts against the vertex's whole response.
    Friction: ``f_t = -k_t z' - b_t v'_t`` with ``z' = z + dt v'_t`` and ``v'_t = v*_t + dt K_t f_t``
    (2x2), solved in closed form, then capped by ``mu_s f`` (sliding: ``mu_d f`` against the motion).
    """
    dt = model.dt
    cb = model.pt_body[model.ct_pt]
    cp, rc = p[:, model.ct_pt], r[:, model.ct_pt]
    if len(cb) == 0:                             # a model without contact vertices
        return cp, cp[0], anchor, f_prev
    depth, fr = contact_frame(model, cp, var)
    if keep is not None and fr.n is not None:
        depth, fr.n, fr.t1, fr.t2 = keep((depth, fr.n, fr.t1, fr.t2))
    touch = depth > 0
    tf = touch.astype(depth.dtype)
    share = []                                  # touching vertices of the vertex's body (>= 1)
    for _, lo, hi in contact_body_ranges(model):
        c = tf[lo:hi].sum(0) if hi - lo > 1 else tf[lo]
        share.append(jnp.broadcast_to(jnp.maximum(c, 1.0), (hi - lo,) + c.shape))
    share = jnp.concatenate(share, 0)
    inv_m = np.where(model.fixed[cb], 0.0, 1.0 / model.mass[cb])[:, None]
    if var is not None:                          # a body s times as heavy: K / s
        share = share / var.mass[cb]
    K = contact_inverse_mass(model)
    Rc = R[:, :, cb]
    nb_, t1b, t2b = fr.in_body(Rc)
    vstar = pv[:, model.ct_pt] + dt * (a[:, cb] + cross(alpha[:, cb], rc))
    kn = share * _quad(K, nb_, nb_)
    carry_n = dt * (share * inv_m - kn) * f_prev
    k11 = share * _quad(K, t1b, t1b)
    k12 = share * _quad(K, t1b, t2b)
    k22 = share * _quad(K, t2b, t2b)
    fc, new_anchor, fn = contact_law(model, depth, fr, cp, anchor, fr.comp(vstar), (kn, k11, k12, k22), carry_n,
                                     None, var)
    return fc, depth, new_anchor, fn


def contact_law(model, depth, fr, cp, anchor, vs, k, carry_n, carry_t=None, var=None):
    """Eq. 3.7's ground and the friction bristle, solved implicitly at each touching vertex: the one contact law
    of both pipelines (the springs' free bodies, :func:`contact_forces`; exact joints, `sim.exact.contact`).

    ``depth`` [nc, B] and the terrain frame ``fr`` under the vertices at ``cp`` [3, nc, B]; ``anchor`` [3, nc, B]
    the bristles' anchors; ``vs = (v_n, v_1, v_2)``: each vertex's velocity at the end of the step under every
    force but its own contact force, in the frame; ``k = (kn, k11, k12, k22)``: the frame components of its
    inverse-mass matrix (``n.K.n``, ``t1.K.t1``, ``t1.K.t2``, ``t2.K.t2``, already scaled for the vertices that
    push together); ``carry_n`` [nc, B]: added to the predicted normal velocity (the part of the prediction that
    the pipeline counts for the vertex's force of the previous step), ``carry_t = (c1, c2)`` likewise for the
    tangential velocity (``None``: nothing).  Returns the world contact forces [3, nc, B], the new anchors and the
    normal forces [nc, B].
    """
    dt = model.dt
    kn, k11, k12, k22 = k
    vs_n, vs_1, vs_2 = vs
    touch = depth > 0
    A, B = ground(model, var)
    fa = A * depth
    vn = vs_n + dt * kn * fa + carry_n
    fn = jnp.where(touch, jnp.maximum(fa - B * vn / (1.0 + dt * B * kn), 0.0), 0.0)
    # friction: f = -(K + I/(dt b'))^-1 (v* + k z / b') / dt,  b' = b + k dt (the bristle implicit too)
    z = cp - anchor
    kb, bp = bristle(model, var)
    z_n, z_1, z_2 = fr.comp(z)
    if carry_t is not None:
        vs_1, vs_2 = vs_1 + carry_t[0], vs_2 + carry_t[1]
    s1, s2 = vs_1 + (kb / bp) * z_1, vs_2 + (kb / bp) * z_2
    reg = 1.0 / (dt * bp)
    k11 = k11 + reg
    k22 = k22 + reg
    g = -1.0 / (dt * (k11 * k22 - k12 * k12))
    f1 = g * (k22 * s1 - k12 * s2)
    f2 = g * (k11 * s2 - k12 * s1)
    mu_s, mu_d = friction(model, var)
    stick = jnp.sqrt(f1 * f1 + f2 * f2) <= mu_s * fn
    vmag = jnp.sqrt(s1 * s1 + s2 * s2 + 1e-20)
    slide = -(mu_d * fn / vmag)
    f1, f2 = jnp.where(stick, f1, slide * s1), jnp.where(stick, f2, slide * s2)
    new_anchor = trail_anchor(model, fr, cp, anchor, (z_1, z_2), touch, stick, fn, var)
    return jnp.where(touch, fr.world(fn, f1, f2), 0.0), new_anchor, fn


def bristle(model, var=None):
    """The friction bristle's spring ``k`` and its damper made implicit, ``b' = b + k dt`` (per robot with a
    :class:`~cpgjax.sim.variation.Variation`'s bristle scale)."""
    kb = model.friction_k if var is None else model.friction_k * var.bristle
    return kb, model.friction_b + kb * model.dt


def ground(model, var=None):
    """Eq. 3.7's stiffness A and damping B, per robot with a ``Variation``'s ``stiffness`` and ``damping``."""
    A, B = model.ground_A, model.ground_B
    if var is not None and var.stiffness is not None:
        A = A * var.stiffness
    if var is not None and var.damping is not None:
        B = B * var.damping
    return A, B


def friction(model, var=None):
    """The static and dynamic friction coefficients (Appendix B), per robot with a ``Variation``."""
    if var is None:
        return model.mu_static, model.mu_dynamic
    return model.mu_static * var.friction, model.mu_dynamic * var.friction


def trail_anchor(model, fr, cp, anchor, z_t, touch, stick, fn, var=None):
    """The bristles' new anchors: fixed while a vertex sticks; sliding, the anchor trails the vertex so that the
    bristle holds at most ``mu_d f_n``; off the ground (or not pushing), the vertex itself.  ``z_t = (z_1, z_2)``:
    the bristle's tangential stretch ``cp - anchor`` in the terrain frame."""
    z_1, z_2 = z_t
    kb, _ = bristle(model, var)
    _, mu_d = friction(model, var)
    zmag = jnp.sqrt(z_1 * z_1 + z_2 * z_2 + 1e-18)
    trail = jnp.minimum(1.0, mu_d * fn / kb / zmag)
    trailed = cp - fr.world(jnp.zeros_like(z_1), trail * z_1, trail * z_2)
    return jnp.where(touch, jnp.where(stick, anchor, trailed), cp)
