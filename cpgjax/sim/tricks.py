"""What the simulator does for XLA's CPU compiler (jaxlib 0.10), in one place.

None of it changes a value: without any of it a step computes the same quantities, only in other fused
kernels (and so, where a fusion changes, with another rounding in the last bit).  What each buys
(docs/results/performance.md has the figures; ``cpgjax bench --tricks --pipeline exact`` measures
:func:`keep` again, with and without it, in one run):

- :func:`keep`: values computed once into memory.  XLA's CPU fusion puts an intermediate into every fusion
  that reads it and computes it there again, per element read (the roots' 6x6 solve of the exact pipeline
  was recomputed for each of the nine bodies' velocity components; on uneven ground the springs pipeline's
  contact frame for every component and body sum that reads it).  The largest of the tricks: every stage of
  the exact pipeline (:func:`stage`), and on uneven ground the springs pipeline's contact frame and forces.
- :func:`take`: static item lists as slices and broadcasts, not gathers (a gather does not fuse with what
  follows; what gathers cost the exact step: docs/exact-joints.md, *What the code does for XLA's compiler*).
- :func:`sum0`: a short sum over a leading axis as a chain of adds (XLA's reduce over a 6-long leading axis
  was the slowest kernel of the exact step in a profile; docs/exact-joints.md).
- :func:`rot_const`, :func:`rot_const_row`, :func:`column`, :func:`mul`: products with constants known when
  the program is traced leave out the terms that are zero (XLA does not fold ``0 * x`` for floats: it would
  change ``0 * inf``).
- :func:`poly_atan2`: a polynomial ``atan2`` in place of the library's, off (the model's ``poly_atan2``): it
  bought nothing on the pinned versions and is kept to measure that on others.
- :func:`add_at`: an indexed add of static rows as adds and a stack, not a scatter (a scatter is a kernel of its
  own that nothing fuses with: the exact step launched 6 kernels fewer at 16 robots, with the same bits).
"""

from __future__ import annotations

import functools

import jax
import jax.numpy as jnp
import numpy as np


def keep(tree, on: bool = True):
    """``tree``, computed once into memory (``on``: on the exact pipeline the model's ``exact.materialize``; off,
    ``tree`` itself).

    `jax.lax.optimization_barrier` does not do it (XLA's CPU compiler drops the barriers before fusion); a loop
    does (its operands must be in memory), so the values pass through a ``while_loop`` that runs zero times: its
    condition is always false but opaque to the compiler, ``(bits | 1) == 0`` on the bits of the first value it
    carries (a condition on a step counter, ``n < 0``, was folded by the loop analysis).  The body must change
    its carry (``+ 1``): XLA would forward an unchanged one.  A ``cond`` with an always true predicate, the first
    form, did the same but copied every array in its taken branch; a zero-trip loop keeps its operands' buffers.
    """
    if not on:
        return tree
    first = next((i for i, x in enumerate(jax.tree.leaves(tree)) if jnp.size(x)), None)
    if first is None:
        return tree

    def never(t):
        x = jax.tree.leaves(t)[first].reshape(-1)[0]
        if jnp.issubdtype(x.dtype, jnp.floating):
            x = jax.lax.bitcast_convert_type(x, {2: jnp.int16, 4: jnp.int32, 8: jnp.int64}[x.dtype.itemsize])
        return (x | 1) == 0

    return jax.lax.while_loop(never, lambda t: jax.tree.map(lambda a: a + 1, t), tree)


def stage(fn):
    """A stage of the step: ``fn(model, ...)``'s result passes through :func:`keep` (the model's
    ``exact.materialize`` says whether), so that each later stage reads it from memory."""

    @functools.wraps(fn)
    def run(model, *args, **kw):
        return keep(fn(model, *args, **kw), model.exact.materialize)

    return run


def sum0(x):
    """``x.sum(0)`` as a chain of adds in a fixed order."""
    out = x[0]
    for i in range(1, x.shape[0]):
        out = out + x[i]
    return out


def take(x, idx):
    """``x[..., idx, :]`` for static indices, as a slice or a broadcast wherever it is one."""
    idx = np.asarray(idx)
    n = len(idx)
    if n == x.shape[-2] and np.array_equal(idx, np.arange(n)):
        return x
    i0 = int(idx[0]) if n else 0
    if n and (idx == i0).all():                 # one item to many: a broadcast
        one = x[..., i0:i0 + 1, :]
        return one if n == 1 else jnp.broadcast_to(one, x.shape[:-2] + (n, x.shape[-1]))
    if n and np.array_equal(idx, np.arange(i0, i0 + n)):
        return x[..., i0:i0 + n, :]
    step = int(idx[1] - idx[0]) if n > 1 else 0
    if step > 1 and np.array_equal(idx, i0 + step * np.arange(n)):   # every step-th item: a strided slice
        return jax.lax.slice_in_dim(x, i0, i0 + step * (n - 1) + 1, stride=step, axis=x.ndim - 2)
    # runs of consecutive or repeated items, each a slice or a broadcast, concatenated (a gather made XLA
    # put the items in front of the components, with a transpose in every fusion reading it)
    runs, start = [], 0
    for i in range(1, n + 1):
        if i == n or not (idx[i] == idx[i - 1] + 1 and idx[start] != idx[start + 1 if start + 1 < n else start]
                          or idx[i] == idx[i - 1] and (i - start == 1 or idx[start] == idx[start + 1])):
            runs.append(take(x, idx[start:i]))
            start = i
    return jnp.concatenate(runs, axis=-2)


def gather_sum(x, slots):
    """``out[..., i, :] = sum_s x[..., slots[s, i], :]`` over the valid slots (static, -1 padded), in slot order
    (:func:`take` for each slot)."""
    out = None
    for row in slots:
        valid = row >= 0
        if not valid.any():
            continue
        t = take(x, np.maximum(row, 0))
        if not valid.all():
            t = t * valid.astype(np.float32)[:, None]
        out = t if out is None else out + t
    if out is None:
        return jnp.zeros(x.shape[:-2] + (slots.shape[1], x.shape[-1]), x.dtype)
    return out


def rot_const(R, r):
    """``R @ r`` for R [3, 3, n, B] and constant vectors r [3, n] (components zero for every item left out)."""
    out = 0.0
    for j in range(3):
        if np.any(r[j]):
            out = out + R[:, j] * jnp.asarray(r[j], R.dtype)[:, None]
    return out if not isinstance(out, float) else jnp.zeros(R.shape[:1] + R.shape[2:], R.dtype)


def rot_const_row(R, i, col):
    """``(R @ c)[i]`` for constant vectors c [3, n]."""
    out = 0.0
    for k in range(3):
        if np.any(col[k]):
            out = out + R[i, k] * jnp.asarray(col[k], R.dtype)[:, None]
    return out if not isinstance(out, float) else jnp.zeros(R.shape[2:], R.dtype)


def column(R, axis_index):
    """Column ``axis_index[i]`` of each item's R [3, 3, n, B] (a slice when every item has the same)."""
    ai = np.asarray(axis_index)
    if (ai == ai[0]).all():
        return R[:, int(ai[0])]
    out = 0.0
    for j in range(3):
        if (ai == j).any():
            out = out + R[:, j] * jnp.asarray((ai == j).astype(np.float32), R.dtype)[:, None]
    return out


def mul(a, b):
    """``a * b`` where either may be a constant known when tracing: None (zero: the product is None) or 1.0."""
    if a is None or b is None:
        return None
    if isinstance(a, float):
        return b if a == 1.0 else a * b
    if isinstance(b, float):
        return a if b == 1.0 else a * b
    return a * b



def add_at(x, idx, y):
    """``x.at[idx].add(y)`` along the leading axis for static, distinct indices, without a scatter: the rows of
    ``x`` that ``idx`` names get ``x[idx[i]] + y[i]``, the others stay ``x``'s."""
    idx = np.asarray(idx)
    where = -np.ones(x.shape[0], np.int64)
    where[idx] = np.arange(len(idx))
    return jnp.stack([x[k] + y[where[k]] if where[k] >= 0 else x[k] for k in range(x.shape[0])])



def poly_atan2(y, x):
    """Polynomial atan2, max error about 1e-5 rad; the joint angles use it where the model's ``poly_atan2`` is set.

    Why it exists: a prototype found the library atan2 slow inside XLA's fused CPU loops and this minimax
    polynomial faster.  On the pinned versions it buys nothing (``cpgjax bench --tricks``; docs/results/performance.md,
    *Where the step's time goes*), so it is off by default and kept for that comparison on other versions.
    """
    ax, ay = jnp.abs(x), jnp.abs(y)
    swap = ay > ax
    num = jnp.where(swap, ax, ay)
    den = jnp.where(swap, ay, ax)
    a = num / jnp.where(den == 0, 1.0, den)
    s = a * a
    r = ((((-0.0117212 * s + 0.05265332) * s - 0.11643287) * s + 0.19354346) * s - 0.33262347) * s + 0.99997723
    r = r * a
    r = jnp.where(swap, np.pi / 2 - r, r)
    r = jnp.where(x < 0, np.pi - r, r)
    return jnp.where(y < 0, -r, r)
