"""One record per real image, in the three forms a detection run gives: JSON, a CSV row, and
the printed line.

Every grasp (the record's `grasp` and each of its `candidates`) is also a `pose`, a 4x4
homogeneous transform from the gripper's frame to the camera's (OpenCV: x right, y down, z
forward; metres): its columns are the gripper's x axis = the closing direction
(`closing_axis`), y = z x x (along the jaws' edges), z = the approach direction (`approach`,
into the scene), and its translation the grasp centre G (`position`) on the target's top
surface; the jaws reach `depth` below G along z. The frame is the simulated gripper's
(`geometry.frame_from_axes`). The CSV gives it as `pose_00` ... `pose_33`, row by row. With
the camera's pose (`--camera-pose`, camera to world) each grasp is also `pose_world`, the
same pose in the world frame (the camera's pose times `pose`; CSV `pose_world_00` ...).
"""

from __future__ import annotations

import json
from collections.abc import Sequence

import numpy as np

from graspjax.disk import jsonable
from graspjax.geometry import frame_from_axes
from graspjax.imagefiles.batches import Detection
from graspjax.imagefiles.inputs import Inputs
from graspjax.perception.workspace import block_factors
from graspjax.schema import detect_columns


def grasp_pose(position, closing_axis, approach) -> np.ndarray | None:
    """A grasp as a 4x4 pose in the camera frame (the module's convention): rotation columns
    closing axis, approach x closing axis, approach; translation the grasp centre. None
    where there is no grasp (a non-finite position)."""
    if not np.isfinite(position).all():
        return None
    pose = np.eye(4)
    pose[:3, :3] = np.asarray(frame_from_axes(np.asarray(approach), np.asarray(closing_axis)))
    pose[:3, 3] = position
    return pose


def in_world(pose: np.ndarray | None, camera_pose: np.ndarray | None) -> np.ndarray | None:
    """A grasp's pose (4, 4) in the world frame: `camera_pose` (camera to world) times `pose`
    (gripper to camera); None without either."""
    return None if pose is None or camera_pose is None else camera_pose @ pose


def record(d: Detection) -> dict:
    """The record of one image's `Detection` (JSON values: lists, numbers, strings, None), at
    the resolution it was detected at (`Detection.inputs`); each grasp's `pose` as the module
    docstring says."""
    r, camera, inputs = d.result, d.camera, d.inputs
    g, a, s, ranked = r.grasp, r.alignment, r.support, r.ranked
    fine, coarse = block_factors(inputs.width, inputs.image)
    pose = grasp_pose(r.position, r.closing_axis, r.approach)
    return jsonable({
        "image": str(d.path),
        "method": inputs.config.method,
        "found": bool(r.found),
        "reason": r.reason_name,
        "size": list(inputs.source_size),
        "full_resolution": [inputs.width, inputs.height],
        "input_reduction": inputs.reduction,
        "working_resolution": [inputs.width // fine, inputs.height // fine],
        "downsample": fine,
        "support_resolution": [inputs.width // coarse, inputs.height // coarse],
        "window": inputs.image.crop_px,
        "camera": {"fx": camera.fx, "fy": camera.fy, "cx": camera.cx, "cy": camera.cy,
                   "source": d.source},  # at full resolution; pixels below are the file's
        "camera_pose": inputs.camera_pose,  # camera to world, as given (None: not given)
        "workspace": {"roi": list(inputs.roi) if inputs.roi else None, "mask": inputs.mask,
                      "bin": inputs.image.bin,
                      "range": [inputs.image.min_depth, inputs.image.max_depth],
                      "pixels": int(d.workspace.sum())},
        "support_plane": {"found": bool(s.found), "reason": s.reason_name,
                          "normal": s.normal, "distance": s.distance,
                          "tilt_deg": np.rad2deg(s.tilt), "inliers": int(s.inliers),
                          "inlier_fraction": s.fraction},
        "view": "virtual" if bool(r.virtual) else "camera",
        "view_rotation": r.rotation,
        "window_camera": {"fx": r.view.fx, "fy": r.view.fy, "cx": r.view.cx, "cy": r.view.cy},
        "target": {"reason": r.target_reason_name,
                   "tried": int(r.targets_tried),
                   "tried_reasons": r.tried_reason_names,
                   "pixel": inputs.source_pixel(r.target_pixel), "point": r.target_point,
                   "height": r.target_height},
        "grasp": {"found": bool(r.found), "reason": g.reason_name,
                  "position": r.position, "closing_axis": r.closing_axis,
                  "approach": r.approach,
                  "pose": pose, "pose_world": in_world(pose, inputs.camera_pose),
                  "width": g.width, "depth": g.depth,
                  "contact_width": ranked.contact_width[0], "clearance": ranked.clearance[0],
                  "landing_fall": ranked.landing[0],
                  "score": ranked.score[0], "surface_depth": g.surface_depth,
                  "pixel": inputs.source_pixel(r.pixel),
                  "surface_pixels": int(g.surface_pixels),
                  "valid_candidates": int(g.candidates.valid.sum())},
        "candidates": [_candidate(ranked, k, r.approach, inputs) for k in range(len(ranked.valid))
                       if ranked.valid[k]],
        "alignment": {"found": bool(a.found), "reason": a.reason_name,
                      "normal": r.plane_normal, "point": r.plane_point,
                      "inliers": int(a.inliers), "counts": a.counts},
        "timing": {"load_ms": 1e3 * d.load_s, "compute_ms": 1e3 * d.compute_s},
    })


def _candidate(ranked, k: int, approach, inputs: Inputs) -> dict:
    """The record of the grasp ranked k + 1 (JSON values; its pixel in the file's); every
    grasp of an image shares the `approach` (the view's axis)."""
    return {"rank": k + 1, "score": ranked.score[k], "target": int(ranked.target[k]) + 1,
            "position": ranked.position[k], "closing_axis": ranked.closing_axis[k],
            "pose": (pose := grasp_pose(ranked.position[k], ranked.closing_axis[k], approach)),
            "pose_world": in_world(pose, inputs.camera_pose),
            "pixel": inputs.source_pixel(ranked.pixel[k]), "width": ranked.width[k],
            "contact_width": ranked.contact_width[k], "depth": ranked.depth[k],
            "clearance": ranked.clearance[k], "landing_fall": ranked.landing[k],
            "no_depth_fraction": ranked.unknown[k],
            "centre_distance": ranked.centre_distance[k],
            "placed_by": "contour" if bool(ranked.contour[k]) else inputs.config.method}


def csv_rows(rec: dict) -> list[list]:
    """The CSV rows (`schema.detect_columns()`) of a record: one per ranked grasp, or one saying why none."""
    s, t, a = rec["support_plane"], rec["target"], rec["alignment"]
    nan3 = [None] * 3
    image = [rec["image"], rec["found"], rec["reason"]]
    rest = [*t["pixel"], t["height"], t["tried"], rec["view"], s["reason"], *s["normal"],
            s["distance"], s["tilt_deg"], s["inlier_fraction"], a["reason"], *a["normal"],
            rec["timing"]["load_ms"], rec["timing"]["compute_ms"], rec["method"]]
    approach = rec["grasp"]["approach"]
    rows = [image + [c["rank"], c["score"], c["target"], *c["position"], *c["closing_axis"],
                     *approach, c["width"], c["contact_width"], c["depth"], c["clearance"],
                     c["landing_fall"], *c["pixel"]] + rest + [c["placed_by"]]
            + [v for row in c["pose"] for v in row]
            + ([v for row in c["pose_world"] for v in row] if c["pose_world"] is not None
               else [None] * 16)
            for c in rec["candidates"]]
    return rows or [image + [None] * 3 + nan3 + nan3 + nan3 + [None] * 5 + [None, None] + rest
                    + [None] + [None] * 32]


def csv_bytes(records: Sequence[dict]) -> bytes:
    """The results table: a row per ranked grasp of each image (one if none), nan as an empty
    cell."""
    import pandas as pd

    frame = pd.DataFrame([row for r in records for row in csv_rows(r)], columns=detect_columns())
    frame["rank"] = frame["rank"].astype("Int64")
    frame["target"] = frame["target"].astype("Int64")
    return frame.to_csv(index=False, float_format="%.6g").encode()


def json_bytes(records: Sequence[dict], many: bool) -> bytes:
    """The JSON file: the one record, or the list of them."""
    return (json.dumps(list(records) if many else records[0], indent=2) + "\n").encode()


def line(rec: dict) -> str:
    """The printed line of one record (several images)."""
    text = f"{rec['image']}: {rec['reason']}"
    if rec["found"]:
        x, y, z = rec["grasp"]["position"]
        text += (f", width {100 * rec['grasp']['width']:.1f} cm at ({x:+.3f}, {y:+.3f}, {z:.3f}) m"
                 f", pixel ({rec['grasp']['pixel'][0]:.0f}, {rec['grasp']['pixel'][1]:.0f})")
        if len(rec["candidates"]) > 1:
            text += f" (best of {len(rec['candidates'])} ranked)"
    support = rec["support_plane"]
    if support["found"]:
        text += f"; {rec['view']} view, support tilt {support['tilt_deg']:.1f} deg"
    elif support["reason"] == "TOO_TILTED":
        text += (f"; no support plane: the table is {support['tilt_deg']:.0f} deg off the optical "
                 "axis, past image.max_plane_tilt_deg")
    return text
