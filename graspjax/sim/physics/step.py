"""The physics step of one world (`step`, the package's door): MJX's step with the reworked
collision (`collision`) and constraint solver (`solver`), its scatters of model indices turned
into gathers (`scatters`); or, with `kind="mjx"`, plain `mjx.step`.
"""

from __future__ import annotations

import functools

import numpy as np

from graspjax.privates import impl, quiet_import
from graspjax.sim.physics import solver
from graspjax.sim.physics.collision import collision
from graspjax.sim.physics.scatters import without_sorted_scatters

mjx = quiet_import("mujoco.mjx")  # mjx prints that its optional backends are missing

STEPS = ("graspjax", "mjx")  # the kinds of step `step` takes (`SimConfig.step`)


def step(model: mjx.Model, data: mjx.Data, geom_owner: np.ndarray, skip_far: bool,
         kind: str = "graspjax") -> mjx.Data:
    """One physics step of one world. `geom_owner` (ngeom,) int: STATIC, HAND or the object
    index of each geom; `skip_far`: skip the narrow phase of pairs far apart in every world
    (kind "graspjax" only); `kind`: one of `STEPS` (module docstring)."""
    if kind == "mjx":
        return mjx.step(model, data)
    return reworked_step(model, data, geom_owner, skip_far)


def reworked_step(m: mjx.Model, d: mjx.Data, geom_owner: np.ndarray, skip_far: bool = True
                  ) -> mjx.Data:
    """The scenes' physics step: MJX's, with `solver.solve` (the elliptic cone's Hessian as one
    product) and `collision` (skipping far pairs when `skip_far`; `geom_owner`: as for
    `collision`) in place of MJX's."""
    return _step_function(tuple(np.asarray(geom_owner).tolist()), skip_far)(m, d)


@functools.cache
def _step_function(geom_owner: tuple[int, ...], skip_far: bool):
    """`step`'s function of (m, d) for a scene, its scatters of model indices gathered
    (`scatters.without_sorted_scatters`): jitted, so each scene's step is traced and rewritten
    once per process, input types and model statics, and whether the axis of worlds is bound
    (and its size), however many loops of a program call it."""
    owner = np.asarray(geom_owner)
    return without_sorted_scatters(
        lambda m, d: step_with(m, d, lambda m, d: collision(m, d, owner, skip_far), solver.solve))


def step_with(m: mjx.Model, d: mjx.Data, collide, solve=mjx.solve) -> mjx.Data:
    """`mjx.step` with `collide(m, d)` and `solve(m, d)` in place of MJX's collision and
    constraint solver: `constrained`, the solver, then MJX's Euler integrator (the scenes'
    integrator)."""
    if m.opt.integrator != mjx.IntegratorType.EULER:
        raise NotImplementedError(f"graspjax steps with Euler only, not {m.opt.integrator}")
    d = constrained(m, d, collide)
    if impl(d).efc_J.size == 0:
        d = d.replace(qacc=d.qacc_smooth)
    else:
        d = mjx.sensor_acc(m, solve(m, d))
    return mjx.euler(m, d)


def constrained(m: mjx.Model, d: mjx.Data, collide) -> mjx.Data:
    """MJX's forward dynamics stage by stage up to its constraint solver, with `collide(m, d)`
    in place of its collision: the data the solver starts from."""
    for stage in (mjx.kinematics, mjx.com_pos, mjx.camlight, mjx.tendon, mjx.crb,
                  mjx.tendon_armature, mjx.factor_m):
        d = stage(m, d)
    d = collide(m, d)
    for stage in (mjx.make_constraint, mjx.transmission, mjx.sensor_pos, mjx.fwd_velocity,
                  mjx.sensor_vel, mjx.fwd_actuation, mjx.fwd_acceleration):
        d = stage(m, d)
    return d
