"""Debug figures like the paper's Figs. 2-5 and 8.

Each view gets three panels: the depth image with z_min; the surface cluster
with its straight edges, every antipodal T-beam placement and the chosen
grasp; the alignment triangles with the winning plane's inliers.
`debug_figure` draws one image; `attempt_figure` a simulated attempt's
overview and every view it took (`graspjax report DIR --debug N`).
"""

from __future__ import annotations

import io

import jax
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.patches import Polygon

from graspjax.camera import Camera
from graspjax.config import Config
from graspjax.perception import Alignment, Grasp, GraspReason, plane_inliers
from graspjax.perception.grasp import surface_contour


def _finger_outlines(center_px, axis, camera: Camera, z: float, config: Config):
    """Pixel outlines `(2, 4, 2)` of both opened fingers of a T-beam at `center_px`."""
    g = config.gripper
    along = np.array([-axis[1], axis[0]])
    inner, outer, half = g.opening / 2, g.opening / 2 + g.finger_thickness, g.finger_width / 2
    px = np.array([camera.fx / z, camera.fy / z], float)
    shapes = []
    for side in (1.0, -1.0):
        corners = [side * a * axis + b * along for a, b in
                   ((inner, -half), (outer, -half), (outer, half), (inner, half))]
        shapes.append(center_px + np.array(corners) * px)
    return np.array(shapes)


def debug_figure(depth: np.ndarray, camera: Camera, grasp: Grasp, alignment: Alignment,
                 config: Config = Config(), title: str = "") -> bytes:
    """PNG bytes of the three-panel debug figure for one image."""
    depth = np.asarray(depth, np.float32)
    seed, cluster, z_s, contour = jax.jit(surface_contour)(depth, config.detect)
    fig = Figure(figsize=(15, 4.6), dpi=110)
    FigureCanvasAgg(fig)
    draw_view(fig, fig.subplots(1, 3), depth, camera, grasp, alignment, np.asarray(seed),
              np.asarray(cluster), float(z_s), contour, config)
    return _png(fig, title)


def attempt_figure(saved, config: Config = Config()) -> bytes:
    """PNG bytes of one simulated attempt (`views.SavedAttempt`): the overview with the
    target, then one row of three panels per view the procedure took."""
    from graspjax.camera import Camera

    height, width = saved.depth.shape[1:]
    camera = Camera(width, height, *map(float, saved.camera))
    rows = [v for v in range(len(saved.looked) - 1) if saved.looked[v + 1]]
    fig = Figure(figsize=(15, 4.6 * (len(rows) + 1)), dpi=90)
    FigureCanvasAgg(fig)
    axes = fig.subplots(len(rows) + 1, 3, squeeze=False)
    shown = np.where(saved.depth[0] > 0, saved.depth[0], np.nan)
    image = axes[0, 0].imshow(shown, cmap="viridis", interpolation="nearest")
    fig.colorbar(image, ax=axes[0, 0], fraction=0.035, label="depth (m)")
    outline = np.zeros((*shown.shape, 4))
    outline[saved.target_mask[0]] = (1.0, 0.2, 0.2, 0.5)
    axes[0, 0].imshow(outline, interpolation="nearest")
    axes[0, 0].set_title("overview: the target (red) holds z_min")
    for ax in axes[0, 1:]:
        ax.axis("off")
    for r, v in enumerate(rows, start=1):
        grasp, alignment, contour = saved.view(v)
        draw_view(fig, axes[r], saved.depth[v + 1], camera, grasp, alignment, saved.seed[v],
                  saved.cluster[v], float(saved.surface_depth[v]), contour, config,
                  label="centred view" if v == 0 else f"re-aligned view {v}")
    return _png(fig, saved.label)


def _png(fig, title: str) -> bytes:
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    return buffer.getvalue()


def draw_view(fig, axes, depth, camera: Camera, grasp: Grasp, alignment: Alignment, seed,
              cluster, z_s: float, contour, config: Config, label: str = "depth") -> None:
    """Three panels of one view: depth and z_min; the surface with its edges and T-beams; the
    alignment triangles and the winning plane's inliers."""
    inliers = np.asarray(jax.jit(plane_inliers)(depth, camera, alignment, config.align))
    shown = np.where(np.isfinite(depth) & (depth > 0), depth, np.nan)
    for ax in axes:
        ax.set_xlim(-0.5, camera.width - 0.5)
        ax.set_ylim(camera.height - 0.5, -0.5)
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])

    im = axes[0].imshow(shown, cmap="viridis", interpolation="nearest")
    fig.colorbar(im, ax=axes[0], fraction=0.035, label="depth (m)")
    axes[0].plot(*np.asarray(seed), "r+", ms=12, mew=2, label="z_min")
    axes[0].legend(loc="lower right", fontsize=8)
    axes[0].set_title(f"{label} and nearest point z_min")

    # Zoom panels 2 and 3 on the target: its cluster (and inliers) plus the opened gripper.
    rows, cols = np.nonzero(cluster | inliers)
    if len(rows):
        reach = (config.gripper.opening / 2 + config.gripper.finger_thickness) / z_s
        mu, mv = reach * camera.fx + 4, reach * camera.fy + 4
        for ax in axes[1:]:
            ax.set_xlim(max(cols.min() - mu, -0.5), min(cols.max() + mu, camera.width - 0.5))
            ax.set_ylim(min(rows.max() + mv, camera.height - 0.5), max(rows.min() - mv, -0.5))

    # Surface cluster, contour, edges and T-beams.
    ax = axes[1]
    ax.imshow(np.where(cluster, 0.75, np.where(np.isnan(shown), 0.0, 0.25)), cmap="gray",
              vmin=0, vmax=1, interpolation="nearest")
    pts = np.asarray(contour.points)[: int(contour.length)]
    if len(pts):
        ax.plot(pts[:, 0], pts[:, 1], ".", color="0.5", ms=2)
    edges = jax.tree.map(np.asarray, grasp.edges)
    scale = np.array([camera.fx, camera.fy]) / z_s
    centre_px = edges.center * scale + [camera.cx, camera.cy]
    for i in np.flatnonzero(edges.valid):
        half = edges.direction[i] * edges.length[i] / 2 * scale
        ends = np.array([centre_px[i] - half, centre_px[i] + half])
        ax.plot(ends[:, 0], ends[:, 1], "-", color=f"C{i % 10}", lw=2.5)
        tip = centre_px[i] + edges.normal[i] * 3
        ax.plot([centre_px[i][0], tip[0]], [centre_px[i][1], tip[1]], "-", color=f"C{i % 10}", lw=1)
    cands = jax.tree.map(np.asarray, grasp.candidates)
    shown_reasons = cands.reason >= GraspReason.TOO_WIDE  # antipodal placements that fit or nearly
    for m in np.flatnonzero(shown_reasons):
        colour = "tab:green" if cands.valid[m] else "tab:red"
        for outline in _finger_outlines(cands.pixel[m], cands.axis[m], camera, z_s, config):
            ax.add_patch(Polygon(outline, closed=True, fill=False, ec=colour, lw=0.6, alpha=0.5))
    if bool(grasp.found):
        m = int(grasp.index)
        for outline in _finger_outlines(cands.pixel[m], cands.axis[m], camera, z_s, config):
            ax.add_patch(Polygon(outline, closed=True, fill=True, fc="tab:blue", alpha=0.6))
        ax.plot(*cands.pixel[m], "bx", ms=10, mew=2)
    status = (f"grasp: width {float(grasp.width) * 100:.1f} cm" if bool(grasp.found)
              else f"no grasp: {GraspReason(int(grasp.reason)).name}")
    ax.set_title(f"surface, edges, T-beams ({status})")

    # Alignment.
    ax = axes[2]
    ax.imshow(shown, cmap="gray", interpolation="nearest")
    overlay = np.zeros((*inliers.shape, 4))
    overlay[inliers] = (1.0, 0.2, 0.2, 0.7)
    ax.imshow(overlay, interpolation="nearest")
    corners = np.asarray(alignment.corners)
    counts = np.asarray(alignment.counts)
    for k in range(len(corners)):
        best = k == int(alignment.best)
        ax.add_patch(Polygon(corners[k], closed=True, fill=False,
                             ec="yellow" if best else "cyan", lw=2 if best else 0.8))
    ax.plot(*np.asarray(alignment.anchor), "r+", ms=12, mew=2)
    if bool(alignment.found):
        n = np.asarray(alignment.normal)
        ax.set_title(f"alignment: {int(alignment.inliers)} inliers, "
                     f"normal ({n[0]:+.2f}, {n[1]:+.2f}, {n[2]:+.2f})")
    else:
        ax.set_title(f"alignment: none ({int(counts.max(initial=0))} inliers at best)")
