"""The physics step of one world, behind one door: `step`.

`kind="graspjax"` (the default, `sim.step`) is MJX's step reworked for speed, with MJX's
results up to float32 rounding: the narrow phase skipped for pairs far apart in every world
of a batch (`collision`), hull pairs collided on pair grids (`convex`), the elliptic cone's
Newton Hessian as one product (`solver`), and scatters of model indices computed by gathers
(`scatters`). `kind="mjx"` is plain `mjx.step`, to check the rework against (the physics tests
run both). Every private MJX or JAX name the rework needs comes from `graspjax.privates`.
"""

from __future__ import annotations

import numpy as np

from graspjax.privates import quiet_import
from graspjax.sim.physics.collision import HAND, OBJECTS, STATIC, WORLDS
from graspjax.sim.physics.collision import step as reworked_step

mjx = quiet_import("mujoco.mjx")  # mjx prints that its optional backends are missing

STEPS = ("graspjax", "mjx")  # the kinds of step `step` takes (`SimConfig.step`)

__all__ = ["HAND", "OBJECTS", "STATIC", "STEPS", "WORLDS", "step"]


def step(model: mjx.Model, data: mjx.Data, geom_owner: np.ndarray, skip_far: bool,
         kind: str = "graspjax") -> mjx.Data:
    """One physics step of one world. `geom_owner` (ngeom,) int: STATIC, HAND or the object
    index of each geom; `skip_far`: skip the narrow phase of pairs far apart in every world
    (kind "graspjax" only); `kind`: one of `STEPS` (module docstring)."""
    if kind == "mjx":
        return mjx.step(model, data)
    return reworked_step(model, data, geom_owner, skip_far)
