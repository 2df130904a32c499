"""Does a capture hold grasps that `graspjax detect`'s own jaw checks accept but its search
never proposes? Every grasp on a dense grid through `perception.jaws.check_jaws`, judged.

    python experiments/exhaustive_jaws.py IMAGE (--intrinsics FILE | --fx FX --fy FY --cx CX
        --cy CY) [--roi x0,y0,x1,y1] [--preset paper|realistic] [--set key=value ...]
        [--stride 3] [--angle-step 15] [--csv OUT]

A miss of the detector is either its search's (a grasp its checks would pass was never tried)
or its checks' (none passes): this tells them apart. `graspjax detect` runs once for the
support plane and the view's approach. Then a grasp is tried at every `--stride`-th pixel of
the workspace box (and `--margin` rows below it: parts pushed past its edge) standing
`--min-height` above the support, for every closing direction `--angle-step` apart across the
support plane (0 deg: approach x the camera's x, about the image's columns; 90: about its
rows). Its band is close to the T-beam's rule: the stretch along the closing axis within
`detect.surface_tolerance` of the centre's height, sampled every millimetre on the jaws'
height map (`perception.jaws.height_map`, built as the detector builds it, on a grid of the
full image's size; its rule fills the cells no point falls in). The grasp is centred on that
band, across and in depth (the band's mean level, as the detector's centre stands at its
band's mean depth), and checked with the preset's settings (`check_jaws`, the same call the
detector makes).
Every grasp that passes is judged by `judge_real_depth.py`. The bands are the depth band's
only (not the followed surface's, which the contour search also pairs on), so the grid is not
a superset of the detector's proposals; its grasps at other heights and directions are.
Prints the detector's targets (height, reason), the reasons' counts and every grasp that
passes or fails on the wall check alone; `--csv` writes one row per grasp tried. Takes a
`.npy` of metres that `graspjax detect` keeps at its full resolution (the judge reads it).
The captures stay outside the repository.
"""

from __future__ import annotations

import argparse
import csv
import importlib.util
import sys
from collections import Counter
from pathlib import Path

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.arguments import UsageError, detect_settings
from graspjax.codes import GraspReason
from graspjax.errors import InputError
from graspjax.imagefiles.batches import detect_files
from graspjax.imagefiles.inputs import IntrinsicsRequest, prepare
from graspjax.perception.cluster import valid_mask
from graspjax.perception.jaws import check_jaws, height_map
from graspjax.perception.support import plane_height
from graspjax.perception.virtual import view_camera
from graspjax.perception.window import in_view

BAND_REACH = 0.045  # how far each side of the centre a band may run (m): past half the opening
SAMPLE = 0.001  # between a band's samples (m)
CHUNK = 20000  # grasps per compiled call


def _judge():
    path = Path(__file__).with_name("judge_real_depth.py")
    spec = importlib.util.spec_from_file_location("judge_real_depth", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.judge


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("image")
    parser.add_argument("--intrinsics", help="intrinsics file (else --fx --fy --cx --cy)")
    for name in ("fx", "fy", "cx", "cy"):
        parser.add_argument(f"--{name}", type=float)
    parser.add_argument("--roi", help="workspace box x0,y0,x1,y1 (default: the whole image)")
    parser.add_argument("--preset", default="paper", choices=["paper", "realistic"])
    parser.add_argument("--set", action="append", default=[], help="key=value, as for detect")
    parser.add_argument("--stride", type=int, default=3, help="pixels between grasp centres")
    parser.add_argument("--angle-step", type=float, default=15.0, help="degrees between axes")
    parser.add_argument("--min-height", type=float, default=0.02,
                        help="centres stand this high above the support plane (m)")
    parser.add_argument("--margin", type=int, default=20, help="rows below the box also tried")
    parser.add_argument("--csv", help="write one row per grasp tried here")
    args = parser.parse_args()
    if args.intrinsics:
        request = IntrinsicsRequest(file=args.intrinsics)
    elif None not in (args.fx, args.fy, args.cx, args.cy):
        request = IntrinsicsRequest(focal=(args.fx, args.fy), centre=(args.cx, args.cy))
    else:
        parser.error("give --intrinsics or all of --fx --fy --cx --cy")
    roi = tuple(int(v) for v in args.roi.split(",")) if args.roi else None
    try:
        inputs = prepare([args.image], intrinsics=request, roi=roi,
                         overrides=detect_settings(args.preset, None, args.set))
    except (InputError, UsageError, ValueError) as error:
        print(f"exhaustive_jaws: {error}", file=sys.stderr)
        return 2
    if inputs.reduction > 1 or Path(args.image).suffix != ".npy":
        print("exhaustive_jaws: give a .npy that detect keeps at its resolution "
              f"(this one is reduced {inputs.reduction} times or not a .npy)", file=sys.stderr)
        return 2
    result = next(iter(detect_files(inputs))).result
    depth, camera, _ = inputs.read(Path(args.image))
    config, image = inputs.config, inputs.image
    if not bool(result.support.found):
        print("no support plane: nothing to measure heights from", file=sys.stderr)
        return 1
    approach = jnp.asarray(result.approach, jnp.float32)
    normal, distance = np.asarray(result.support.normal), float(result.support.distance)

    # Grasp centres: every stride-th pixel in the box (and a margin below it) standing up.
    d = np.asarray(depth, np.float32)
    known = np.asarray(valid_mask(d)) & (d >= image.min_depth) & (d <= image.max_depth)
    full = jnp.asarray(np.where(known, d, 0.0))  # as the detector hands its jaws' checks
    x0, y0, x1, y1 = roi or (0, 0, d.shape[1], d.shape[0])
    v, u = np.mgrid[y0:min(y1 + args.margin, d.shape[0]):args.stride, x0:x1:args.stride]
    keep = known[v, u]
    u, v = u[keep], v[keep]
    z = d[v, u]
    points = np.asarray(camera.unproject(jnp.asarray(np.stack([u, v], -1), jnp.float32),
                                         jnp.asarray(z)))
    height = plane_height(points, normal, distance)
    standing = height >= args.min_height
    points, height = points[standing], height[standing]

    # Closing axes across the support plane (perpendicular to the approach).
    angles = np.deg2rad(np.arange(0.0, 180.0, args.angle_step))
    first = np.cross(np.asarray(approach), [1.0, 0.0, 0.0])
    first /= np.linalg.norm(first)
    second = np.cross(np.asarray(approach), first)
    axes = np.cos(angles)[:, None] * first + np.sin(angles)[:, None] * second
    centre_index, axis_index = (g.ravel() for g in np.meshgrid(
        np.arange(len(points)), np.arange(len(axes)), indexing="ij"))

    across = jnp.arange(0.0, BAND_REACH + 1e-6, SAMPLE, dtype=jnp.float32)
    side = jnp.array([1.0, -1.0], jnp.float32)
    tolerance = config.detect.surface_tolerance
    # The jaws' height map as the detector builds it (`real_image.detect_real_image`), here on
    # a grid of the full image's size (the detector's has its detection view's).
    rotation = jnp.asarray(result.rotation, jnp.float32)
    view_depth = np.asarray(result.views.depth)
    reference = np.median(view_depth[view_depth > 0])
    heights = height_map(full, camera, rotation, view_camera(camera, rotation),
                         jnp.float32(reference), in_view(result.support, rotation),
                         image.sweep_fill_px)

    def one(centre, axis):
        """The band through `centre` along `axis` (the T-beam's rule) on the height map, and its
        jaws checked (camera frame in and out; the check in the view frame)."""
        c, a = rotation.T @ centre, rotation.T @ axis
        rise = heights.lookup(c[:2] + side[:, None, None] * across[None, :, None] * a[:2])[0] - c[2]
        inside = jnp.abs(rise) <= tolerance  # (2, A) along each side
        ends = jnp.argmin(jnp.concatenate([inside, jnp.zeros((2, 1), bool)], 1), 1)
        extent = jnp.where(ends > 0, across[jnp.maximum(ends - 1, 0)] + SAMPLE / 2, 0.0)  # (2,)
        width = extent[0] + extent[1]
        band = inside & (jnp.arange(across.shape[0]) < ends[:, None])
        level = jnp.sum(jnp.where(band, rise, 0.0)) / jnp.maximum(jnp.sum(band), 1)
        centred = c + (extent[0] - extent[1]) / 2 * a + level * jnp.array([0.0, 0.0, 1.0])
        check = check_jaws(heights, centred, a, width, config.detect, config.gripper, image)
        return check, width, rotation @ centred

    checked = jax.jit(jax.vmap(one))
    parts, total = [], len(centre_index)
    padded = -total % CHUNK  # every call one size: one compile
    centres = np.concatenate([centre_index, np.zeros(padded, int)])
    directions = np.concatenate([axis_index, np.zeros(padded, int)])
    for start in range(0, total, CHUNK):
        chunk = slice(start, start + CHUNK)
        check, width, centred = checked(jnp.asarray(points[centres[chunk]], jnp.float32),
                                        jnp.asarray(axes[directions[chunk]], jnp.float32))
        parts.append(jax.tree.map(np.asarray, (check.reason, check.landing, check.contact_width,
                                               width, centred)))
    reason, landing, contact, width, centred = (np.concatenate(p)[:total]
                                                for p in zip(*parts, strict=True))

    view_height = np.asarray(result.views.height)
    tried = [f"{1e3 * view_height[v_, u_]:.0f} mm {GraspReason(int(why)).name}" for (u_, v_), why in
             zip(np.asarray(result.tried_pixels)[:int(result.targets_tried)],
                 np.asarray(result.tried_reasons)[:int(result.targets_tried)], strict=True)]
    print(f"{args.image}: detector {'found a grasp' if bool(result.found) else 'found none'}; "
          f"its targets: {', '.join(tried)}")
    print(f"{len(points)} centres x {len(axes)} axes = {len(reason)} grasps")
    grasp_height = plane_height(centred, normal, distance)
    for code, count in sorted(Counter(reason.tolist()).items()):
        print(f"  {GraspReason(code).name}: {count}")
    judge = _judge()
    record = dict(image=str(Path(args.image).resolve()), workspace=dict(roi=list(roi) if roi else None),
                  camera=dict(fx=float(camera.fx), fy=float(camera.fy), cx=float(camera.cx),
                              cy=float(camera.cy)))
    verdicts = {}
    shown = (reason == GraspReason.FOUND) | (reason == GraspReason.NO_WALL)
    for i in np.nonzero(shown)[0]:
        ok, text = judge(record, dict(position=centred[i].tolist(),
                                      closing_axis=axes[axis_index[i]].tolist(),
                                      width=float(width[i])))
        verdicts[i] = ok
        pixel = np.asarray(camera.project(jnp.asarray(centred[i])))
        what = "passes" if reason[i] == GraspReason.FOUND else "fails the wall check alone"
        print(f"  {what}: pixel {pixel[0]:.0f},{pixel[1]:.0f}, {1e3 * grasp_height[i]:.0f} mm "
              f"up, axis {np.rad2deg(angles[axis_index[i]]):.0f} deg, band {1e3 * width[i]:.0f} mm, "
              f"contact {1e3 * contact[i]:.0f} mm, landing {1e3 * landing[i]:.1f} mm; judge: "
              f"{'straddles' if ok else 'does not straddle'} ({text})")
    if args.csv:
        with open(args.csv, "w", newline="") as out:
            writer = csv.writer(out)
            writer.writerow(["x", "y", "z", "height", "axis_deg", "band_width", "reason",
                             "landing", "contact_width", "judge_straddles"])
            for i in range(len(reason)):
                writer.writerow([*np.round(centred[i], 5), round(float(grasp_height[i]), 5),
                                 round(float(np.rad2deg(angles[axis_index[i]])), 1),
                                 round(float(width[i]), 5), GraspReason(int(reason[i])).name,
                                 round(float(landing[i]), 5), round(float(contact[i]), 5),
                                 verdicts.get(i, "")])
    return 0


if __name__ == "__main__":
    sys.exit(main())
