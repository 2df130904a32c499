"""Who owns a geom, and the axis of worlds: the names the physics step and the scenes share.

A scene's `geom_owner` (ngeom,) int gives each geom's owner: `STATIC` (the table, the bin),
`HAND` (the gripper) or the index i >= 0 of the object it belongs to; a pair of two objects'
geoms is owned by `OBJECTS`. A batch's worlds are the `jax.vmap` axis named `WORLDS`.
"""

WORLDS = "worlds"  # the name of the vmapped axis of worlds (`jax.vmap(..., axis_name=WORLDS)`)
STATIC, HAND, OBJECTS = -3, -2, -1  # owners of geoms besides object i >= 0 (OBJECTS: a pair of two)
