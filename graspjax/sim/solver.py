"""MJX's Newton constraint solver, with the elliptic cone's Hessian assembled cone by cone.

MJX (`solver._update_gradient`) builds the Newton Hessian of an elliptic-cone model as
`J.T @ C @ J` with `C` a dense (nefc, nefc) matrix: the active rows' `efc_D` on its diagonal
and each contact's cone Hessian (condim, condim) scatter-added onto its block. In a pile of 48
contact slots that is a (153, 153) matrix, 48 scatter-adds per solver iteration (sorted, under
XLA's deterministic ops) and two matrix products over it, for a matrix that is block
diagonal. Here the same Hessian is the sum of its parts:

    H = M + J.T diag(efc_D * active) J + sum over cones c of J_c.T H_c J_c

with J_c the contact's rows of J, gathered by their static addresses. The solver's loop, line
search and stopping rule are MJX's own (`solver.Context`, `_linesearch`, `_update_constraint`,
private: mujoco-mjx is pinned to the minor version this was written against); only the order
of the Hessian's float32 sums differs (tests/test_solver.py compares both).
"""

from __future__ import annotations

import contextlib
import io

import jax
import jax.numpy as jnp
import numpy as np

with contextlib.redirect_stdout(io.StringIO()):  # mjx prints optional-backend warnings
    from mujoco import mjx
    from mujoco.mjx._src import math as mjx_math
    from mujoco.mjx._src import solver as mjx_solver
    from mujoco.mjx._src import support


def solve(m: mjx.Model, d: mjx.Data) -> mjx.Data:
    """`mjx.solve`, with `newton_step` for the Newton solver with elliptic cones (other
    solvers and cones: MJX's own)."""
    if m.opt.solver != mjx.SolverType.NEWTON or m.opt.cone != mjx.ConeType.ELLIPTIC:
        return mjx.solve(m, d)

    def unfinished(ctx):  # MJX's stopping rule: iterations, improvement, gradient
        improvement = mjx_solver._rescale(m, d, ctx.prev_cost - ctx.cost)
        gradient = mjx_solver._rescale(m, d, mjx_math.norm(ctx.grad))
        done = ((ctx.solver_niter >= m.opt.iterations) | (improvement < m.opt.tolerance)
                | (gradient < m.opt.tolerance))
        return ~done

    def iteration(ctx):
        ctx = mjx_solver._linesearch(m, d, ctx)
        ctx = newton_step(m, d, mjx_solver._update_constraint(m, d, ctx))
        return ctx.replace(solver_niter=ctx.solver_niter + 1)

    if not m.opt.disableflags & mjx.DisableBit.WARMSTART:  # start from the better of the two
        warm = mjx_solver.Context.create(m, d.replace(qacc=d.qacc_warmstart), grad=False)
        smooth = mjx_solver.Context.create(m, d.replace(qacc=d.qacc_smooth), grad=False)
        d = d.replace(qacc=jnp.where(warm.cost < smooth.cost, d.qacc_warmstart, d.qacc_smooth))
    else:
        d = d.replace(qacc=d.qacc_smooth)
    ctx = newton_step(m, d, mjx_solver.Context.create(m, d, grad=False))
    ctx = iteration(ctx) if m.opt.iterations == 1 else jax.lax.while_loop(unfinished, iteration, ctx)
    return d.tree_replace({"qfrc_constraint": ctx.qfrc_constraint, "qacc": ctx.qacc,
                           "_impl.efc_force": ctx.efc_force})


def hessian(m: mjx.Model, d: mjx.Data, ctx) -> jax.Array:
    """The Newton Hessian (nv, nv) of the elliptic-cone cost at the solver context `ctx`,
    symmetrized as MJX symmetrizes it."""
    jac = d._impl.efc_J  # (nefc, nv)
    h = (jac.T * (d._impl.efc_D * ctx.active)) @ jac
    dim = np.asarray(d._impl.contact.dim)
    cones = dim > 1
    dims, rows = dim[cones], np.asarray(d._impl.contact.efc_address)[cones]
    for condim in np.unique(dims):  # the contacts of one cone size together
        which = np.flatnonzero(dims == condim)
        block = jac[rows[which, None] + np.arange(condim)]  # (n, condim, nv)
        cone = ctx.h[which, :condim, :condim]  # (n, condim, condim)
        h = h + jnp.einsum("cai,cab,cbj->ij", block, cone, block)
    h = support.full_m(m, d) + h
    return (h + h.T) * 0.5


def newton_step(m: mjx.Model, d: mjx.Data, ctx):
    """The context with its gradient, the Newton direction `Mgrad` (H^-1 grad) and the next
    search direction (-Mgrad), as MJX's Newton iteration updates them."""
    grad = ctx.Ma - d.qfrc_smooth - ctx.qfrc_constraint
    mgrad = jax.scipy.linalg.cho_solve(jax.scipy.linalg.cho_factor(hessian(m, d, ctx)), grad)
    return ctx.replace(grad=grad, Mgrad=mgrad, search=-mgrad)
