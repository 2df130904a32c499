"""MJX's Newton constraint solver, with the elliptic cone's Hessian assembled as one product.

MJX (`solver._update_gradient`) builds the Newton Hessian of an elliptic-cone model as
`J.T @ C @ J` with `C` a dense (nefc, nefc) matrix: the active rows' `efc_D` on its diagonal
and each contact's cone Hessian (condim, condim) scatter-added onto its block. In a pile of 48
contact slots that is a (153, 153) matrix, 48 scatter-adds per solver iteration (sorted, under
XLA's deterministic ops) and two matrix products over it, for a matrix that is block
diagonal. Here `C J` is built row by row without forming `C`:

    H = M + J.T W,   W_r = efc_D_r active_r J_r + (H_c J_c)_a   (row r = row a of cone c)

with J_c the cone's rows of J, gathered by their static addresses, and `H_c J_c` sums of at
most 6 products (elementwise). One matrix product per iteration: under deterministic ops XLA
does not autotune its matrix kernels, and a product per cone size was the step's largest cost.

MJX's constraint update (`_update_constraint`, run when the context is made and in every
iteration) writes each cone's zone, forces and friction forces into their efc rows with
scatters. Under XLA's deterministic GPU ops every scatter whose indices are not declared unique
becomes a sort of its (index, value) pairs, dozens of kernels at the batch of the tables: the
bin scene stepped at half the speed of the non-deterministic build. The addresses are static,
so `update_constraint` reads the same values per row with gathers instead; it computes what
MJX's computes, operation for operation (equal to float32 rounding: XLA may fuse it otherwise).
MJX's line search (the friction rows' quadratics added onto the normal rows) and its
kinematic-tree sums still scatter; `scatters.without_sorted_scatters` gathers them for the whole
physics step.

The solver's loop, line search and stopping rule are MJX's own (`solver.Context`,
`_linesearch`, private: mujoco-mjx is pinned to the minor version this was written against);
only the order of the Hessian's float32 sums differs (tests/test_solver.py compares both).
"""

from __future__ import annotations

from typing import NamedTuple

import jax
import jax.numpy as jnp
import mujoco
import numpy as np

from graspjax import privates
from graspjax.privates import impl, quiet_import

mjx = quiet_import("mujoco.mjx")  # mjx prints that its optional backends are missing

MIN_VALUE = mujoco.mjMINVAL  # MuJoCo's floor of divisors (cone and frictionloss terms)


def solve(m: mjx.Model, d: mjx.Data) -> mjx.Data:
    """`mjx.solve`, with `context`, `update_constraint` and `newton_step` for the Newton solver
    with elliptic cones (other solvers and cones, or no cone contact: MJX's own)."""
    if (m.opt.solver != mjx.SolverType.NEWTON or m.opt.cone != mjx.ConeType.ELLIPTIC
            or not cones(d).dims.size):
        return mjx.solve(m, d)

    def unfinished(ctx):  # MJX's stopping rule: iterations, improvement, gradient
        improvement = privates.rescale(m, d, ctx.prev_cost - ctx.cost)
        gradient = privates.rescale(m, d, privates.norm(ctx.grad))
        done = ((ctx.solver_niter >= m.opt.iterations) | (improvement < m.opt.tolerance)
                | (gradient < m.opt.tolerance))
        return ~done

    def iteration(ctx):
        ctx = privates.linesearch(m, d, ctx)
        ctx = newton_step(m, d, update_constraint(m, d, ctx))
        return ctx.replace(solver_niter=ctx.solver_niter + 1)

    if not m.opt.disableflags & mjx.DisableBit.WARMSTART:  # start from the better of the two
        warm = context(m, d.replace(qacc=d.qacc_warmstart))
        smooth = context(m, d.replace(qacc=d.qacc_smooth))
        d = d.replace(qacc=jnp.where(warm.cost < smooth.cost, d.qacc_warmstart, d.qacc_smooth))
    else:
        d = d.replace(qacc=d.qacc_smooth)
    ctx = newton_step(m, d, context(m, d))
    ctx = iteration(ctx) if m.opt.iterations == 1 else jax.lax.while_loop(unfinished, iteration, ctx)
    return privates.with_impl(d.replace(qfrc_constraint=ctx.qfrc_constraint, qacc=ctx.qacc),
                              efc_force=ctx.efc_force)


def context(m: mjx.Model, d: mjx.Data) -> privates.SolverContext:
    """MJX's solver context at `d.qacc` (`solver.Context.create` without the gradient), for
    data with at least one cone contact: the regularized cone's friction `fri` (ncone, 6), its
    columns past each contact's condim zero, then the constraint update."""
    zero = jnp.zeros(m.nv, d.qacc.dtype)
    layout = cones(d)
    friction = impl(d).contact.friction[layout.mask]  # (ncone, 5)
    mu = friction[:, 0] / jnp.sqrt(m.opt.impratio)
    fri = jnp.concatenate((mu[:, None], friction), axis=1)
    fri = jnp.where(np.arange(6) < layout.dims[:, None], fri, 0.0)
    ctx = privates.SolverContext(
        qacc=d.qacc, qfrc_constraint=d.qfrc_constraint,
        Jaref=impl(d).efc_J @ d.qacc - impl(d).efc_aref, efc_force=impl(d).efc_force,
        Ma=privates.mul_m(m, d, d.qacc), grad=zero, Mgrad=zero, search=zero, gauss=0.0,
        cost=jnp.inf, prev_cost=0.0, solver_niter=0, active=0.0, fri=fri, dm=0.0, u=0.0, h=0.0)
    return update_constraint(m, d, ctx)


class Cones(NamedTuple):
    """The elliptic cones' static layout in the efc rows (fixed when the model is built)."""

    mask: np.ndarray  # (ncon,) bool: the contact is a cone (condim > 1)
    dims: np.ndarray  # (ncone,) each cone's condim
    rows: np.ndarray  # (ncone,) each cone's first efc row (its normal)
    owner: np.ndarray  # (nefc,) the cone an efc row belongs to, -1: none
    offset: np.ndarray  # (nefc,) a row's place in its cone (0: the normal, 1...: frictions), -1

    def window(self, x: jax.Array) -> jax.Array:
        """MJX's 6-row window of efc rows per cone, from its normal row on, of `x` (nefc, ...):
        (ncone, 6, ...), rows past the last efc row zero."""
        padded = jnp.concatenate((x, jnp.zeros((5,) + x.shape[1:], x.dtype)))
        return padded[self.rows[:, None] + np.arange(6)]


def cones(d: mjx.Data) -> Cones:
    """The cones' layout of `d`'s contacts (static: from their condims and efc addresses)."""
    dim, address = np.asarray(impl(d).contact.dim), np.asarray(impl(d).contact.efc_address)
    mask = dim > 1
    dims, rows = dim[mask], address[mask]
    owner, offset = np.full((2, impl(d).efc_J.shape[0]), -1)
    for i, (condim, row) in enumerate(zip(dims, rows, strict=True)):
        owner[row:row + condim], offset[row:row + condim] = i, np.arange(condim)
    return Cones(mask, dims, rows, owner, offset)


def update_constraint(m: mjx.Model, d: mjx.Data, ctx: privates.SolverContext) -> privates.SolverContext:
    """MJX's `_update_constraint` for the Newton solver and the elliptic cone (at least one cone
    contact), each efc row's cone values gathered by its static cone index where MJX scatters
    them: the active set (bottom zone), the forces (quadratic rows, plus each cone's middle-zone
    normal and friction forces), the cost, the cones' `u` (ncone, 6), `dm` (ncone,) and
    Hessians `h` (ncone, 6, 6), and the joint-space constraint force."""
    nefc = impl(d).efc_J.shape[0]
    layout = cones(d)
    rows, owner, offset = layout.rows, layout.owner, layout.offset
    cone = np.maximum(owner, 0)  # gather indices (rows of no cone are masked)
    normal_row, friction_row = offset == 0, offset > 0
    always = np.arange(nefc) < impl(d).ne + impl(d).nf  # equality and friction rows
    active = jnp.where(always, True, ctx.Jaref < 0)

    floss_force, floss_cost = jnp.zeros(nefc), 0.0
    if ((impl(m).dof_hasfrictionloss.any() or impl(m).tendon_hasfrictionloss.any())
            and not m.opt.disableflags & mjx.DisableBit.FRICTIONLOSS):
        f, efc_d = impl(d).efc_frictionloss, impl(d).efc_D
        r = 1.0 / (efc_d + (efc_d == 0.0) * MIN_VALUE)
        below, above = (ctx.Jaref <= -r * f) * (f > 0), (ctx.Jaref >= r * f) * (f > 0)
        active = active & ~below & ~above
        floss_force = below * f + above * -f
        floss_cost = jnp.sum(below * (-0.5 * r * f * f - f * ctx.Jaref)
                             + above * (-0.5 * r * f * f + f * ctx.Jaref))

    friction = impl(d).contact.friction[layout.mask]  # (ncone, 5)
    u = layout.window(ctx.Jaref) * ctx.fri  # (ncone, 6)
    mu, n, t = ctx.fri[:, 0], u[:, 0], jax.vmap(privates.norm)(u[:, 1:])

    bottom = ((t <= 0) & (n < 0)) | ((t > 0) & ((mu * n + t) <= 0))  # quadratic zone
    active = jnp.where(owner >= 0, bottom[cone], active)
    efc_force = impl(d).efc_D * -ctx.Jaref * active + floss_force
    cost = 0.5 * jnp.sum(impl(d).efc_D * ctx.Jaref * ctx.Jaref * active)

    middle = (t > 0) & (n < (mu * t)) & ((mu * n + t) > 0)  # the cone's surface
    dm = impl(d).efc_D[rows] / jnp.maximum(mu * mu * (1 + mu * mu), MIN_VALUE)
    nmt = n - mu * t
    cost = cost + 0.5 * jnp.sum(dm * nmt * nmt * middle)
    force = -dm * nmt * mu * middle
    force_fri = (-force / (t + ~middle * MIN_VALUE))[:, None] * u[:, 1:] * friction  # (ncone, 5)
    efc_force = jnp.where(normal_row, efc_force + force[cone], efc_force)
    efc_force = jnp.where(friction_row,
                          efc_force + force_fri[cone, np.clip(offset - 1, 0, 4)], efc_force)

    t = jnp.maximum(t, MIN_VALUE)  # the cone's Newton Hessian
    ttt = jnp.maximum(t * t * t, MIN_VALUE)
    h = (mu * n / ttt)[:, None, None] * (u[:, :, None] * u[:, None, :])  # mu N / T^3 U U'
    h = h + (mu * mu - mu * n / t)[:, None, None] * jnp.eye(6)
    first = jnp.concatenate((jnp.ones_like(mu)[:, None], (-mu / t)[:, None] * u[:, 1:]), 1)
    h = jnp.where((np.arange(6) == 0)[:, None], first[:, None, :], h)  # first row
    h = jnp.where(np.arange(6) == 0, first[:, :, None], h)  # first column
    h = h * (dm[:, None, None] * (ctx.fri[:, :, None] * ctx.fri[:, None, :]))
    h = h * middle[:, None, None]

    gauss = 0.5 * jnp.dot(ctx.Ma - d.qfrc_smooth, ctx.qacc - d.qacc_smooth)
    return ctx.replace(qfrc_constraint=impl(d).efc_J.T @ efc_force, gauss=gauss,
                       cost=cost + gauss + floss_cost, prev_cost=ctx.cost, efc_force=efc_force,
                       active=active, dm=dm, u=u, h=h)


def hessian(m: mjx.Model, d: mjx.Data, ctx) -> jax.Array:
    """The Newton Hessian (nv, nv) of the elliptic-cone cost at the solver context `ctx` (data
    with at least one cone contact, as `solve` calls it), symmetrized as MJX symmetrizes it:
    `M + J' W`, one product over the efc rows, where a row of `W` is its Jacobian row times its
    active weight plus, for a cone's row, that row of the cone block times the cone's rows
    (`H_c J_c`, sums of at most 6 products: elementwise, not small matrix products, which XLA's
    deterministic GPU ops run with untuned kernels)."""
    jac = impl(d).efc_J  # (nefc, nv)
    layout = cones(d)
    window = layout.window(jac)  # (ncone, 6, nv)
    # ctx.h is zero past each cone's condim, so rows of the window past it add nothing
    cone_rows = jnp.sum(ctx.h[:, :, :, None] * window[:, None, :, :], axis=2)  # (ncone, 6, nv)
    in_cone = (layout.owner >= 0)[:, None]
    from_cone = cone_rows[np.maximum(layout.owner, 0), np.maximum(layout.offset, 0)]  # (nefc, nv)
    weighted = jac * (impl(d).efc_D * ctx.active)[:, None] + jnp.where(in_cone, from_cone, 0.0)
    h = privates.full_m(m, d) + jac.T @ weighted
    return (h + h.T) * 0.5


def newton_step(m: mjx.Model, d: mjx.Data, ctx):
    """The context with its gradient, the Newton direction `Mgrad` (H^-1 grad) and the next
    search direction (-Mgrad), as MJX's Newton iteration updates them."""
    grad = ctx.Ma - d.qfrc_smooth - ctx.qfrc_constraint
    mgrad = jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(hessian(m, d, ctx)), grad)
    return ctx.replace(grad=grad, Mgrad=mgrad, search=-mgrad)
