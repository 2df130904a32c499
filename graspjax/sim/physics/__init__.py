"""The physics step of one world, behind one door: `step`.

`kind="graspjax"` (the default, `sim.step`) is MJX's step reworked for speed, with MJX's
results up to float32 rounding: the narrow phase skipped for pairs far apart in every world
of a batch (`collision`), hull pairs collided on pair grids (`convex`), the elliptic cone's
Newton Hessian as one product (`solver`), and scatters of model indices computed by gathers
(`scatters`). `kind="mjx"` is plain `mjx.step`, to check the rework against (the physics tests
run both). Every private MJX or JAX name the rework needs comes from `graspjax.privates`.
"""

from __future__ import annotations

from graspjax.sim.physics.owners import HAND, OBJECTS, STATIC, WORLDS
from graspjax.sim.physics.step import STEPS, step

__all__ = ["HAND", "OBJECTS", "STATIC", "STEPS", "WORLDS", "step"]
