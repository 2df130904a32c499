"""Per-image debug figures, like the paper's Figs. 2-5 and 8.

`attempt_figure`: a simulated attempt (`graspjax report DIR --debug N`): its
overview with the target, then three panels for every view it took: the
depth image with z_min; the surface cluster with its straight edges, every
antipodal T-beam placement and the chosen grasp; the alignment triangles
with the winning plane's inliers. `real_image_figure`: a real image through `detect_real_image`:
the image with its workspace, support plane and the grasp drawn back; the
height above the support in the (possibly virtual) view the target is
chosen in; then the same two detection and alignment panels in the
target's window.
"""

from __future__ import annotations

import jax
import numpy as np
from matplotlib.patches import Polygon

from graspjax.camera import Camera
from graspjax.codes import SupportReason, TargetReason
from graspjax.config import Config, RealImageConfig
from graspjax.figures import new_figure, png
from graspjax.perception import Alignment, Grasp, GraspReason, plane_inliers
from graspjax.perception.grasp import surface_contour


def _finger_offsets(axis, config: Config) -> np.ndarray:
    """Metric outlines `(2, 4, 2)` of both opened fingers around a T-beam centre, closing `axis` (2,)."""
    g = config.gripper
    along = np.array([-axis[1], axis[0]])
    inner, outer, half = g.opening / 2, g.opening / 2 + g.finger_thickness, g.finger_width / 2
    return np.array([[side * a * axis + b * along for a, b in
                      ((inner, -half), (outer, -half), (outer, half), (inner, half))]
                     for side in (1.0, -1.0)])


def _finger_outlines(center_px, axis, camera: Camera, z: float, config: Config):
    """Pixel outlines `(2, 4, 2)` of both opened fingers of a T-beam at `center_px`."""
    px = np.array([camera.fx / z, camera.fy / z], float)
    return center_px + _finger_offsets(axis, config) * px


def _frame(ax, camera: Camera) -> None:
    ax.set_xlim(-0.5, camera.width - 0.5)
    ax.set_ylim(camera.height - 0.5, -0.5)
    ax.set_aspect("equal")
    ax.set_xticks([])
    ax.set_yticks([])


def _shown(depth) -> np.ndarray:
    depth = np.asarray(depth, np.float32)
    return np.where(np.isfinite(depth) & (depth > 0), depth, np.nan)


def _zoom(axes, camera: Camera, region: np.ndarray, z_s: float, config: Config) -> None:
    """Zoom `axes` on `region` (H, W) bool plus the reach of the opened gripper."""
    rows, cols = np.nonzero(region)
    if not len(rows):
        return
    reach = (config.gripper.opening / 2 + config.gripper.finger_thickness) / z_s
    mu, mv = reach * camera.fx + 4, reach * camera.fy + 4
    for ax in axes:
        ax.set_xlim(max(cols.min() - mu, -0.5), min(cols.max() + mu, camera.width - 0.5))
        ax.set_ylim(min(rows.max() + mv, camera.height - 0.5), max(rows.min() - mv, -0.5))


def _draw_detection(ax, depth, camera: Camera, grasp: Grasp, cluster, contour, z_s: float,
                    config: Config) -> None:
    """Surface cluster, contour, straight edges, T-beams and the chosen grasp."""
    ax.imshow(np.where(cluster, 0.75, np.where(np.isnan(_shown(depth)), 0.0, 0.25)), cmap="gray",
              vmin=0, vmax=1, interpolation="nearest")
    pts = np.asarray(contour.points)[: int(contour.length)]
    if len(pts):
        ax.plot(pts[:, 0], pts[:, 1], ".", color="0.5", ms=2)
    edges = jax.tree.map(np.asarray, grasp.edges)
    scale = np.array([camera.fx, camera.fy], float) / z_s
    centre_px = edges.center * scale + [float(camera.cx), float(camera.cy)]
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


def _draw_alignment(ax, depth, alignment: Alignment, inliers: np.ndarray) -> None:
    """Alignment triangles around the anchor and the winning plane's inliers."""
    ax.imshow(_shown(depth), cmap="gray", interpolation="nearest")
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


def _masks(ax, seed_mask: np.ndarray, target_mask: np.ndarray) -> None:
    """Where the method took z_min (white, translucent) and the credited object's pixels by
    the renderer's labels (red: ground truth, never seen by the method)."""
    overlay = np.zeros((*seed_mask.shape, 4))
    overlay[seed_mask] = (1.0, 1.0, 1.0, 0.35)
    overlay[target_mask & ~seed_mask] = (1.0, 0.2, 0.2, 0.45)
    overlay[target_mask & seed_mask] = (1.0, 0.6, 0.6, 0.45)
    ax.imshow(overlay, interpolation="nearest")


def _draw_view(fig, axes, depth, camera: Camera, grasp: Grasp, alignment: Alignment, seed,
               cluster, z_s: float, contour, config: Config, masks, label: str = "depth") -> None:
    """Three panels of one view: depth, z_min and the masks (seed mask, target mask (H, W)
    bool); detection; alignment."""
    inliers = np.asarray(jax.jit(plane_inliers)(depth, camera, alignment, config.align))
    for ax in axes:
        _frame(ax, camera)
    im = axes[0].imshow(_shown(depth), cmap="viridis", interpolation="nearest")
    fig.colorbar(im, ax=axes[0], fraction=0.035, label="depth (m)")
    _masks(axes[0], *masks)
    axes[0].plot(*np.asarray(seed), "r+", ms=12, mew=2, label="z_min")
    axes[0].legend(loc="lower right", fontsize=8)
    axes[0].set_title(f"{label}: target surface (white), object (red), z_min", fontsize=9)
    _zoom(axes[1:], camera, cluster | inliers, z_s, config)
    _draw_detection(axes[1], depth, camera, grasp, cluster, contour, z_s, config)
    _draw_alignment(axes[2], depth, alignment, inliers)


def attempt_figure(saved, config: Config = Config()) -> bytes:
    """PNG bytes of one simulated attempt (`saved_views.SavedAttempt`): the overview with the
    target, then one row of three panels per view the procedure took."""
    height, width = saved.depth.shape[1:]
    camera = Camera(width, height, *map(float, saved.camera))
    rows = [v for v in range(len(saved.looked) - 1) if saved.looked[v + 1]]
    fig = new_figure(15, 4.6 * (len(rows) + 1), dpi=90)
    axes = fig.subplots(len(rows) + 1, 3, squeeze=False)
    _frame(axes[0, 0], camera)
    image = axes[0, 0].imshow(_shown(saved.depth[0]), cmap="viridis", interpolation="nearest")
    fig.colorbar(image, ax=axes[0, 0], fraction=0.035, label="depth (m)")
    _masks(axes[0, 0], saved.seed_mask[0], saved.target_mask[0])
    axes[0, 0].set_title("overview: candidates (white); the credited object (red)", fontsize=9)
    for ax in axes[0, 1:]:
        ax.axis("off")
    for r, v in enumerate(rows, start=1):
        grasp, alignment, contour = saved.view(v)
        _draw_view(fig, axes[r], saved.depth[v + 1], camera, grasp, alignment, saved.seed[v],
                   saved.cluster[v], float(saved.surface_depth[v]), contour, config,
                   (saved.seed_mask[v + 1], saved.target_mask[v + 1]),
                   label="centred view" if v == 0 else f"re-aligned view {v}")
    return png(fig, saved.label)


def _camera_panel(fig, ax, depth: np.ndarray, workspace: np.ndarray, camera: Camera, result,
                  config: Config, image: RealImageConfig) -> None:
    """Panel (a) of `real_image_figure`: the input image with the workspace, the support
    plane's inliers, the target and the grasps drawn back into it."""
    support = result.support
    _frame(ax, camera)
    shown = _shown(depth)
    inside = shown[workspace & np.isfinite(shown)]
    lo, hi = (np.percentile(inside, [1, 99]) if inside.size else (None, None))
    im = ax.imshow(shown, cmap="viridis", vmin=lo, vmax=hi, interpolation="nearest")
    fig.colorbar(im, ax=ax, fraction=0.035, label="depth (m)")
    overlay = np.zeros((*depth.shape, 4))
    overlay[~workspace] = (0.0, 0.0, 0.0, 0.6)
    if bool(support.found):
        points = np.asarray(camera.unproject(camera.pixel_grid(), np.nan_to_num(depth)))
        height = points @ support.normal + support.distance
        on_plane = workspace & np.isfinite(shown) & (np.abs(height) < image.plane_threshold)
        overlay[on_plane] = (1.0, 1.0, 1.0, 0.35)
    ax.imshow(overlay, interpolation="nearest")
    if result.target_reason == TargetReason.FOUND:
        ax.plot(*result.target_pixel, "r+", ms=14, mew=2, label="target")

    def fingers(centre, axis, **style):
        """Both open fingers of a grasp at `centre` (3,) closing along `axis` (2,), both in the
        detection view's frame, drawn in the camera image."""
        for offsets in _finger_offsets(axis / np.linalg.norm(axis), config):
            corners = np.concatenate([centre[:2] + offsets, np.full((4, 1), centre[2])], -1)
            ax.add_patch(Polygon(np.asarray(camera.project(corners @ result.rotation.T)),
                                 closed=True, **style))

    if bool(result.found):
        fingers(result.grasp.position, result.grasp.closing_axis[:2], fill=True, fc="tab:red",
                ec="white", alpha=0.8)
        ax.plot(*result.pixel, "wx", ms=10, mew=2)
    ranked = result.ranked  # the others of the `top_k` ranked grasps: outlined, numbered
    for k in range(1, len(ranked.valid)):
        if not bool(ranked.valid[k]):
            continue
        fingers(result.rotation.T @ ranked.position[k],
                (result.rotation.T @ ranked.closing_axis[k])[:2], fill=False, ec="tab:orange",
                lw=1.5)
        ax.annotate(str(k + 1), ranked.pixel[k], color="tab:orange", fontsize=10,
                    ha="center", va="center", weight="bold")
    reason = (GraspReason(int(result.grasp.reason)).name
              if result.target_reason == TargetReason.FOUND
              else TargetReason(int(result.target_reason)).name)
    ax.set_title(f"camera view: workspace, support inliers, grasp ({reason})")


def _support_panel(fig, ax, result, view_name: str) -> None:
    """Panel (b) of `real_image_figure`: the height above the support plane in the detection
    view (its depth where there is no plane), and the target."""
    views, support = result.views, result.support
    _frame(ax, views.camera)
    if bool(support.found):
        im = ax.imshow(np.where(views.depth > 0, views.height, np.nan), cmap="magma",
                       vmin=0.0, interpolation="nearest")
        fig.colorbar(im, ax=ax, fraction=0.035, label="height above support (m)")
        n = support.normal
        ax.set_title(f"{view_name}\nsupport tilt {np.rad2deg(support.tilt):.1f} deg, normal "
                     f"({n[0]:+.2f}, {n[1]:+.2f}, {n[2]:+.2f}), {support.distance:.3f} m, "
                     f"{100 * support.fraction:.0f}% inliers", fontsize=9)
    else:
        im = ax.imshow(_shown(views.depth), cmap="viridis", interpolation="nearest")
        fig.colorbar(im, ax=ax, fraction=0.035, label="depth (m)")
        tilted = int(support.reason) == SupportReason.TOO_TILTED
        ax.set_title(f"{view_name}: no support plane "
                     f"({SupportReason(int(support.reason)).name}"
                     + (f", {np.rad2deg(support.tilt):.0f} deg" if tilted else "") + ")",
                     fontsize=9)
    if result.target_reason == TargetReason.FOUND:
        ax.plot(*result.target, "c+", ms=14, mew=2)


def real_image_figure(depth: np.ndarray, workspace: np.ndarray, camera: Camera, result,
                      config: Config = Config(), image: RealImageConfig = RealImageConfig(),
                      title: str = "") -> bytes:
    """PNG bytes of the four-panel figure of one real image through `detect_real_image`.

    depth: metric depth (H, W) at full resolution; workspace: (H, W) bool; camera: its
    intrinsics; result: the `RealImageDetection` of this image (single, not batched; its
    `views` are what is drawn).
    """
    depth = np.asarray(depth, np.float32)
    workspace = np.asarray(workspace, bool)
    result = jax.tree.map(np.asarray, result)
    views = result.views
    fig = new_figure(13, 10, dpi=100)
    axes = fig.subplots(2, 2).ravel()

    view_name = "virtual view facing the support" if bool(result.virtual) else "camera view"
    _camera_panel(fig, axes[0], depth, workspace, camera, result, config, image)
    _support_panel(fig, axes[1], result, view_name)

    # (c, d) Detection and alignment in the reported target's window.
    seed = np.zeros(views.window.shape, bool)
    if result.target_reason == TargetReason.FOUND:
        seed[result.grasp.nearest[1], result.grasp.nearest[0]] = True
    _, cluster, z_s, contour = jax.jit(surface_contour)(views.window, config.detect, seed)
    inliers = np.asarray(jax.jit(plane_inliers)(views.window, views.window_camera,
                                                result.alignment, config.align))
    cluster, z_s = np.asarray(cluster), float(z_s)
    for ax in axes[2:]:
        _frame(ax, views.window_camera)
    _draw_detection(axes[2], views.window, views.window_camera, result.grasp, cluster, contour,
                    z_s, config)
    axes[2].set_title(f"{view_name} window, target {int(result.targets_tried)} of "
                      f"{image.max_targets}\n{axes[2].get_title()}", fontsize=9)
    _draw_alignment(axes[3], views.window, result.alignment, inliers)
    return png(fig, title)
