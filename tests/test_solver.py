"""The Newton solver with the elliptic cone's Hessian assembled as one product (`sim/physics/solver.py`)."""

import jax
import numpy as np
import pytest

from graspjax.config import Config, override
from graspjax.sim.physics import solver
from graspjax.sim.physics.step import constrained
from graspjax.sim.scene import build_scene, mjx
from graspjax.sim.world import reset

CUBE = 0


def _constrained(scene, slide: float):
    """The scene's data after MJX's stages up to its constraint solver: the cube 0.5 mm into the
    table, sliding at `slide` m/s along x (its friction in the cone's middle zone), the block
    parked."""
    pos = np.zeros((scene.num_objects, 3))
    pos[CUBE] = (0.0, 0.0, -0.0005)
    pos[1:] = scene.park_pos[1:]
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (scene.num_objects, 1))
    active = np.arange(scene.num_objects) == CUBE
    data = reset(scene, mjx.make_data(scene.mj_model), pos, quat, active)
    qvel = data.qvel.at[scene.object_qvel[CUBE]].set(slide)
    data = data.replace(qvel=qvel)
    return constrained(scene.model, data, mjx.collision)


@pytest.fixture(scope="module")
def sliding():
    """A Setup 1 scene of the cube and the block (elliptic cone) and its sliding cube's data."""
    scene = build_scene(("a", "f"), objects_collide=False)
    return scene, jax.jit(lambda: _constrained(scene, 0.1))()


@pytest.fixture(scope="module", params=[3, 4, 6], ids=lambda c: f"condim{c}")
def sliding_condims(request, sliding):
    """The sliding cube at each contact dimension (`sim.condim`): with 4, a cone's 6-row window in
    the Hessian reaches into the next cone's rows."""
    if request.param == 3:
        return sliding
    sim = override(Config(), [f"sim.condim={request.param}"]).sim
    scene = build_scene(("a", "f"), sim=sim, objects_collide=False)
    return scene, jax.jit(lambda: _constrained(scene, 0.1))()


def test_hessian_is_the_cost_hessian_built_densely(sliding_condims):
    """H = M + J' C J with C the dense (nefc, nefc) matrix: efc_D of active rows on the diagonal,
    each cone's Hessian on its block, built here in float64 from the same context."""
    from mujoco.mjx._src import solver as mjx_solver
    from mujoco.mjx._src import support

    scene, data = sliding_condims
    m = scene.model
    ctx = jax.jit(lambda d: mjx_solver.Context.create(m, d, grad=False))(data)
    ours = np.asarray(jax.jit(lambda d, c: solver.hessian(m, d, c))(data, ctx), np.float64)
    jac = np.asarray(data._impl.efc_J, np.float64)
    dense = np.diag(np.asarray(data._impl.efc_D * ctx.active, np.float64))
    contact = data._impl.contact
    cones = np.asarray(contact.dim) > 1
    blocks = np.asarray(ctx.h, np.float64)
    for i, (addr, condim) in enumerate(zip(np.asarray(contact.efc_address)[cones],
                                           np.asarray(contact.dim)[cones], strict=True)):
        dense[addr:addr + condim, addr:addr + condim] += blocks[i, :condim, :condim]
    assert np.abs(blocks).max() > 0, "no contact in the cone's middle zone: the test is vacuous"
    want = np.asarray(support.full_m(m, data), np.float64) + jac.T @ dense @ jac
    np.testing.assert_allclose(ours, (want + want.T) / 2, rtol=1e-5, atol=1e-6 * np.abs(want).max())


def test_solve_is_mjx_solve_to_float32_rounding(sliding):
    """The constrained accelerations and forces equal MJX's Newton solver's."""
    scene, data = sliding
    m = scene.model
    ours = jax.jit(lambda d: solver.solve(m, d))(data)
    theirs = jax.jit(lambda d: mjx.solve(m, d))(data)
    assert np.abs(np.asarray(theirs._impl.efc_force)).max() > 0
    for field in ("qacc", "qfrc_constraint"):
        want = np.asarray(getattr(theirs, field))
        np.testing.assert_allclose(np.asarray(getattr(ours, field)), want,
                                   atol=1e-5 * np.abs(want).max())
    np.testing.assert_allclose(np.asarray(ours._impl.efc_force), np.asarray(theirs._impl.efc_force),
                               atol=1e-5 * np.abs(np.asarray(theirs._impl.efc_force)).max())


def test_other_cones_solve_with_mjx():
    """The pyramidal cone has no cone blocks: `solve` is MJX's solver itself."""
    sim = override(Config(), ["sim.cone=pyramidal"]).sim
    scene = build_scene(("a",), sim=sim, objects_collide=False)
    data = mjx.make_data(scene.mj_model)
    ours = jax.make_jaxpr(lambda d: solver.solve(scene.model, d))(data)
    theirs = jax.make_jaxpr(lambda d: mjx.solve(scene.model, d))(data)
    assert str(ours) == str(theirs)


def _primitives(jaxpr) -> set[str]:
    """Every primitive's name in a jaxpr, sub-jaxprs (loops, conditionals) included."""
    from jax.extend.core import jaxprs_in_params

    names = set()
    for eqn in jaxpr.eqns:
        names.add(eqn.primitive.name)
        for sub in jaxprs_in_params(eqn.params):
            names |= _primitives(sub)
    return names


@pytest.mark.parametrize("slide", [0.0, 0.1])
def test_constraint_update_is_mjx_s_with_gathers(sliding, slide):
    """`context` (and so `update_constraint`) gives MJX's context field for field, to float32
    rounding: the cube at rest (its cones in the bottom zone: quadratic, active) and sliding
    (in the middle zone: the cone's forces and Hessians)."""
    import dataclasses

    from mujoco.mjx._src import solver as mjx_solver

    scene, data = sliding
    m = scene.model
    if slide == 0.0:
        data = jax.jit(lambda: _constrained(scene, 0.0))()
    ours = jax.jit(lambda d: solver.context(m, d))(data)
    theirs = jax.jit(lambda d: mjx_solver.Context.create(m, d, grad=False))(data)
    owner = solver.cones(data).owner
    cone_active = np.asarray(theirs.active)[owner >= 0]
    if slide == 0.0:
        assert cone_active.any(), "no cone in the bottom zone at rest: the test is vacuous"
    else:
        assert np.abs(np.asarray(theirs.h)).max() > 0, "no cone in the middle zone: vacuous"
    for field in (f.name for f in dataclasses.fields(theirs)):
        want = np.asarray(getattr(theirs, field), np.float64)
        np.testing.assert_allclose(np.asarray(getattr(ours, field), np.float64), want, rtol=1e-6,
                                   atol=1e-6 * max(np.abs(want[np.isfinite(want)]).max(initial=0),
                                                   1e-30), err_msg=field)


def test_constraint_update_has_no_scatters(sliding):
    """Under XLA's deterministic GPU ops a scatter with indices not declared unique becomes a
    sort: the context and the constraint update gather instead (MJX's scatter)."""
    from mujoco.mjx._src import solver as mjx_solver

    scene, data = sliding
    m = scene.model
    scatters = {"scatter", "scatter-add", "scatter_add"}
    theirs = _primitives(jax.make_jaxpr(lambda d: mjx_solver.Context.create(m, d, grad=False))(
        data).jaxpr)
    ours = _primitives(jax.make_jaxpr(lambda d: solver.context(m, d))(data).jaxpr)
    assert theirs & scatters, "MJX's context has no scatter to avoid: the test is vacuous"
    assert not ours & scatters
