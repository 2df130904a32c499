"""A bin's or tote's interior from depth alone (`graspjax detect --bin`), on the host, before
anything is compiled for the batch.

A bin's walls stand up from its floor around the objects; their tops and inner faces are the
highest or nearest surfaces in view, and a T-beam finds a fine grasp on a 1 cm rim. The floor
is the support plane (`perception.support.support_plane`, fitted on the image's pixels in the
workspace); the interior is the convex hull of the floor's largest connected part in the
image, so that objects on the floor (holes in it) and against a wall (notches in it) lie
inside, and the walls, which rise from the floor's edge, outside. The workspace becomes the
user's box (or the whole image) within that hull; the jaws' checks still see the walls (they
see every pixel in the depth range).
"""

from __future__ import annotations

import numpy as np

from graspjax.camera import Camera
from graspjax.config import RealImageConfig
from graspjax.errors import InputError


def bin_interior(depth: np.ndarray, camera: Camera, workspace: np.ndarray,
                 image: RealImageConfig, coarse: tuple[np.ndarray, Camera]) -> np.ndarray:
    """The interior of the bin the image shows (H, W) bool: the convex hull of the largest
    4-connected part of the floor (the support plane's pixels within `plane_threshold`) among
    the `workspace`'s pixels, off the workspace's border where one is. depth: metric depth
    (H, W) of `camera`, 0 where none or outside the workspace or the depth range; coarse: it
    at the support resolution and its camera, where the plane is fitted. An `InputError` when
    no floor is found."""
    import jax
    from scipy import ndimage
    from scipy.spatial import ConvexHull, QhullError

    from graspjax.perception.support import plane_height, support_plane

    height, width = depth.shape
    kept = depth > 0
    plane = jax.tree.map(np.asarray, jax.jit(support_plane)(*coarse, image))
    if not bool(plane.found):
        raise InputError("--bin: no floor found (no support plane in the workspace); give the "
                         "bin's interior with --roi or --mask instead")
    points = np.asarray(camera.unproject(camera.pixel_grid(), depth))
    above = np.asarray(plane_height(points, plane.normal, plane.distance))
    floor = kept & (np.abs(above) < image.plane_threshold)
    parts, count = ndimage.label(floor)
    if count == 0:
        raise InputError("--bin: the floor has no pixels in the workspace")
    sizes = np.asarray(ndimage.sum(floor, parts, index=range(1, count + 1)))
    # The ground around a bin may lie in the floor's plane too; it reaches the workspace's
    # border, the floor of a bin in full view does not: the largest part that stays inside,
    # else (a bin larger than the view) the largest.
    edge = workspace & ~ndimage.binary_erosion(workspace, border_value=0)
    inside = np.setdiff1d(np.arange(1, count + 1), parts[edge])
    if len(inside):
        sizes = np.where(np.isin(np.arange(1, count + 1), inside), sizes, 0)
    largest = 1 + int(np.argmax(sizes))
    v, u = np.nonzero(parts == largest)
    try:
        hull = ConvexHull(np.stack([u, v], -1).astype(np.float64))
    except QhullError:
        raise InputError("--bin: the floor's largest part is a line, not an area") from None
    grid_v, grid_u = np.mgrid[0:height, 0:width]
    pixels = np.stack([grid_u.ravel(), grid_v.ravel(), np.ones(grid_u.size)], 0)
    inside = np.all(hull.equations @ pixels <= 0.5, 0).reshape(height, width)  # half a pixel
    return inside & workspace
