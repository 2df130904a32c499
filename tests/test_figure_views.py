"""The debug figure of a simulated attempt (the real-image figure is drawn by the CLI tests)."""

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.figures.views import attempt_figure
from graspjax.perception.grasp import surface_contour
from graspjax.saved_views import SavedAttempt
from graspjax.synthetic import box


def test_attempt_figure_of_an_overview_and_one_view(camera, detect, align, render):
    depth = render([box((0.04, 0.09, 0.04), yaw=0.3)])
    grasp, plane = detect(jnp.asarray(depth), camera), align(jnp.asarray(depth), camera)
    seed, cluster, z_s, contour = jax.jit(surface_contour)(jnp.asarray(depth))
    views = jax.tree.map(lambda x: np.asarray(x)[None], (grasp, plane, contour))
    saved = SavedAttempt(
        label="box", depth=np.stack([depth, depth]), target_mask=np.stack([depth < 0.49] * 2),
        seed_mask=np.stack([depth < 0.48] * 2),
        looked=np.array([True, True]), camera=np.array([camera.fx, camera.fy, camera.cx, camera.cy]),
        seed=np.asarray(seed)[None], cluster=np.asarray(cluster)[None],
        surface_depth=np.asarray(z_s)[None], contour=views[2], grasp=views[0], alignment=views[1])
    png = attempt_figure(saved)
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
