"""The jaws' height map and two finger sweeps on an analytic scene: docs/figures/jaws_height_map.png.

    python experiments/jaws_height_map_figure.py [OUT.png]

A 4 x 6 x 4 cm box 1 cm from a 12 cm high tote wall on a table, seen from 0.73 m, 40 degrees
off vertical (exact depth, `graspjax.synthetic.analytic_depth`). Left: the depth image. Right:
the height map the jaws' check reads (`perception.jaws.height_map`, seen along the table's
normal), the cells no point fell in hatched, and the fingers' footprints of two grasps on the
box: across it (the +x finger over the wall: `JAWS_BLOCKED`) and along it (both free).
"""

from __future__ import annotations

import sys

import jax.numpy as jnp
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from graspjax.camera import Camera  # noqa: E402
from graspjax.codes import GraspReason  # noqa: E402
from graspjax.config import Config, RealImageConfig  # noqa: E402
from graspjax.perception.jaws import check_jaws, height_map  # noqa: E402
from graspjax.perception.support import SupportPlane  # noqa: E402
from graspjax.perception.virtual import view_camera, view_rotation  # noqa: E402
from graspjax.perception.window import in_view  # noqa: E402
from graspjax.synthetic import analytic_depth, box, rot_x, top_down_pose  # noqa: E402

TILT_DEG, HEIGHT = 40.0, 0.73


def main(out: str = "docs/figures/jaws_height_map.png") -> int:
    camera = Camera(640, 480, 525.0, 525.0, 319.5, 239.5)
    down, _ = top_down_pose(0.0)
    rotation = down @ rot_x(np.deg2rad(TILT_DEG))  # camera to world
    eye = np.array([0.0, 0.0, HEIGHT])
    axis = rotation @ np.array([0.0, 0.0, 1.0])
    centre = (eye + axis * HEIGHT / -axis[2])[:2]  # where the optical axis meets the table
    solids = [box((0.04, 0.06, 0.04), (*centre, 0.0)),
              box((0.01, 0.3, 0.12), (centre[0] + 0.035, centre[1], 0.0))]
    depth = analytic_depth(camera, rotation, eye, solids).astype(np.float32)

    normal = (rotation.T @ np.array([0.0, 0.0, 1.0])).astype(np.float32)
    support = SupportPlane(found=jnp.array(True), reason=jnp.int32(0), normal=normal,
                           distance=jnp.float32(HEIGHT), tilt=jnp.float32(np.deg2rad(TILT_DEG)),
                           inliers=jnp.int32(0), fraction=jnp.float32(1.0))
    turn = view_rotation(normal, jnp.array(True))
    config, image = Config(), RealImageConfig()
    heights = height_map(depth, camera, turn, view_camera(camera, turn), jnp.float32(HEIGHT),
                         in_view(support, turn), image.sweep_fill_px)
    to_view = np.asarray(turn).T @ rotation.T  # world to view
    top = to_view @ (np.array([*centre, 0.04]) - eye)

    gripper = config.gripper
    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.6))
    low, high = np.percentile(depth[depth > 0], [1, 99])
    left.imshow(np.where(depth > 0, depth, np.nan), cmap="viridis", vmin=low, vmax=high)
    left.set_title(f"depth image, {TILT_DEG:.0f} deg off vertical", fontsize=10)
    left.set_axis_off()

    cell = float(heights.cell)
    origin = np.asarray(heights.centre)
    height_above = HEIGHT - np.asarray(heights.depth)  # above the table (m)
    span = 0.12 / cell  # cells each side of the box shown
    c0 = top[:2] / cell + origin
    shown = right.imshow(1e3 * height_above, cmap="magma", vmin=0, vmax=120)
    unseen = ~np.asarray(heights.seen)
    right.contourf(unseen.astype(float), levels=[0.5, 1.5], colors="none", hatches=["////"])
    right.set_xlim(c0[0] - span, c0[0] + span)
    right.set_ylim(c0[1] + span, c0[1] - span)
    fig.colorbar(shown, ax=right, label="height above the table (mm)", fraction=0.046)

    for name, direction, width in (("across", (1.0, 0.0, 0.0), 0.04),
                                   ("along", (0.0, 1.0, 0.0), 0.06)):
        axis_view = (to_view @ np.asarray(direction)).astype(np.float32)
        verdict = check_jaws(heights, jnp.asarray(top, jnp.float32), jnp.asarray(axis_view),
                             jnp.float32(width), config.detect, gripper, image)
        reason = GraspReason(int(verdict.reason)).name
        a = axis_view[:2] / np.linalg.norm(axis_view[:2])
        b = np.array([-a[1], a[0]])
        colour = "tab:green" if reason == "FOUND" else "tab:red"
        for side in (1.0, -1.0):
            inner = gripper.opening / 2
            corners = [top[:2] + side * x * a + y * b
                       for x, y in ((inner, -gripper.finger_width / 2),
                                    (inner + gripper.finger_thickness, -gripper.finger_width / 2),
                                    (inner + gripper.finger_thickness, gripper.finger_width / 2),
                                    (inner, gripper.finger_width / 2))]
            ij = np.array(corners) / cell + origin
            right.fill(ij[:, 0], ij[:, 1], facecolor="none", edgecolor=colour, lw=2)
        fall = 1e3 * float(verdict.landing)
        right.annotate(f"{name}: {reason}\nhighest under a finger: {-fall:+.0f} mm",
                       xy=(c0[0] - 0.95 * span, c0[1] + (0.6 if name == "across" else 0.88) * span),
                       color=colour, fontsize=9, backgroundcolor="white")
    right.set_title("the jaws' height map along the table's normal (hatched: unseen)",
                    fontsize=10)
    right.set_axis_off()
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    print(f"wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(*sys.argv[1:]))
