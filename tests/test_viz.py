"""The per-view debug figure of simulated images (the real-image figure is drawn by the CLI tests)."""

import jax.numpy as jnp

from graspjax.synthetic import box
from graspjax.viz import debug_figure


def test_debug_figure_of_a_simulated_view(camera, detect, align, render):
    depth = render([box((0.04, 0.09, 0.04), yaw=0.3)])
    grasp, plane = detect(jnp.asarray(depth), camera), align(jnp.asarray(depth), camera)
    png = debug_figure(depth, camera, grasp, plane, title="box")
    assert png[:8] == b"\x89PNG\r\n\x1a\n" and len(png) > 10_000
