"""Judge `graspjax detect`'s ranked grasps on real captures, on the raw depth, independently of
the detector's own code.

A grasp "straddles a real object" when its centre stands at least 8 mm above the support plane
(fitted here by a RANSAC of our own on the workspace's raw pixels) and both finger places,
centre +/- closing axis x (width / 2 + 6 mm), lie at least 8 mm below the centre (measured
along the plane's normal) or have no depth.

    python experiments/judge_real_depth.py [--column R] [--finger-offset M] results/real_depth/*/results.json

prints one line per ranked grasp and a summary per file. Reads the images named in the
records (they are not part of the repository). A finger place's depth is the surface seen at
the pixel it projects to (a camera looking far to the side sees there a surface displaced
from the place); with `--column R` (m) it is the highest surface point within R of the
plane's normal through the place, from every pixel of the image (none: no depth), and each
line also says what the pixel gave. `--finger-offset M` (m) moves the finger places (default
6 mm beyond the band's half width), to see how much the verdicts rest on that choice.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

MIN_HEIGHT = 0.008  # the centre above the support plane (m)
MIN_DROP = 0.008  # each finger place below the centre (m)
FINGER_OFFSET = 0.006  # finger places beyond the band's half width (m)


def unproject(u, v, z, cam):
    return np.stack([(u - cam["cx"]) * z / cam["fx"], (v - cam["cy"]) * z / cam["fy"], z], -1)


def support_plane(depth: np.ndarray, workspace: np.ndarray, cam: dict, seed: int = 0,
                  tilt_deg: float = 45.0):
    """(unit normal toward the camera, offset d: n . p + d = height) of the largest plane
    within `tilt_deg` of facing the camera."""
    v, u = np.nonzero(workspace & (depth > 0) & np.isfinite(depth))
    points = unproject(u, v, depth[v, u], cam)[:: max(1, len(u) // 20000)]
    rng = np.random.default_rng(seed)
    best, best_count = None, -1
    for _ in range(500):
        a, b, c = points[rng.choice(len(points), 3, replace=False)]
        n = np.cross(b - a, c - a)
        if np.linalg.norm(n) < 1e-9:
            continue
        n /= np.linalg.norm(n)
        n = -n if n[2] > 0 else n  # toward the camera
        if -n[2] < np.cos(np.deg2rad(tilt_deg)):
            continue
        count = int(np.sum(np.abs((points - a) @ n) < 0.005))
        if count > best_count:
            best, best_count = (n, -a @ n), count
    return best


def judge(rec: dict, candidate: dict, column: float | None = None,
          finger_offset: float = FINGER_OFFSET, tilt_deg: float = 45.0) -> tuple[bool, str]:
    """Whether `candidate` straddles an object, and the numbers that say so; the support plane
    the largest within `tilt_deg` of facing the camera."""
    depth = _read(rec["image"])
    cam = rec["camera"]
    height, width = depth.shape
    workspace = np.zeros_like(depth, bool)
    roi = rec["workspace"]["roi"] or [0, 0, width, height]
    workspace[roi[1]:roi[3], roi[0]:roi[2]] = True
    normal, offset = support_plane(depth, workspace, cam, tilt_deg=tilt_deg)
    centre = np.asarray(candidate["position"])
    axis = np.asarray(candidate["closing_axis"])
    h_centre = centre @ normal + offset
    places = [centre + side * axis * (candidate["width"] / 2 + finger_offset) for side in (1, -1)]
    at_pixel = [_drop(h_centre, _seen_at_pixel(depth, cam, place, normal, offset))
                for place in places]
    drops = at_pixel
    if column is not None:
        v, u = np.nonzero((depth > 0) & np.isfinite(depth))
        points = unproject(u, v, depth[v, u], cam)
        drops = [_drop(h_centre, column_top(points, place, normal, offset, column))
                 for place in places]
    ok = h_centre >= MIN_HEIGHT and all(d is None or d >= MIN_DROP for d in drops)
    text = f"centre {1000 * h_centre:.0f} mm up, fingers drop {_mm(drops)}"
    return ok, text + (f" (at the pixel: {_mm(at_pixel)})" if column is not None else "")


def _read(path: str) -> np.ndarray:
    """Metric depth (H, W) float64 of an .npy, or of an .npz's `depth`; nan = no depth."""
    data = np.load(path)
    depth = data["depth"] if Path(path).suffix == ".npz" else data
    return np.asarray(depth, np.float64).squeeze()


def _drop(centre_height: float, height: float | None) -> float | None:
    """How far a finger place lies below the centre (None: no depth there)."""
    return None if height is None else centre_height - height


def _mm(drops: list) -> str:
    return ", ".join("no depth" if d is None else f"{1000 * d:.0f} mm" for d in drops)


def _seen_at_pixel(depth, cam, place, normal, offset):
    """The height above the plane of the surface seen at the pixel `place` projects to (None:
    no depth or outside the image)."""
    height, width = depth.shape
    u, v = (np.array([cam["fx"] * place[0] / place[2] + cam["cx"],
                      cam["fy"] * place[1] / place[2] + cam["cy"]])).round().astype(int)
    z = depth[v, u] if (0 <= u < width and 0 <= v < height) else 0.0
    if not (z > 0 and np.isfinite(z)):
        return None
    return unproject(u, v, z, cam) @ normal + offset


def column_top(points, place, normal, offset, radius):
    """The height above the plane of the highest of `points` (N, 3) within `radius` of the
    plane's normal through `place` (None: none)."""
    relative = points - place
    along = relative @ normal
    near = np.einsum("ij,ij->i", relative, relative) - along ** 2 <= radius ** 2
    return float(np.max(points[near] @ normal) + offset) if np.any(near) else None


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", nargs="+", help="results.json files of graspjax detect")
    parser.add_argument("--column", type=float, default=None, metavar="R",
                        help="a finger place's depth: the highest point within R (m) of the "
                             "plane's normal through it, not the surface seen at its pixel")
    parser.add_argument("--finger-offset", type=float, default=FINGER_OFFSET, metavar="M",
                        help="finger places this far (m) beyond the band's half width "
                             f"(default {FINGER_OFFSET})")
    args = parser.parse_args(argv)
    if args.column is not None and not args.column > 0:
        parser.error(f"--column must be > 0 (m), got {args.column}")
    if not args.finger_offset >= 0:
        parser.error(f"--finger-offset must be >= 0 (m), got {args.finger_offset}")
    for path in args.results:
        records = json.loads(Path(path).read_text())
        records = records if isinstance(records, list) else [records]
        good = 0
        for rec in records:
            name = Path(rec["image"]).name
            if not rec["candidates"]:
                print(f"{path} {name}: no grasp ({rec['reason']})")
                continue
            for c in rec["candidates"]:
                ok, text = judge(rec, c, args.column, args.finger_offset)
                good += ok and c["rank"] == 1
                print(f"{path} {name} rank {c['rank']}: {'straddles' if ok else 'QUESTIONABLE'}"
                      f" (width {100 * c['width']:.1f} cm, contact {100 * c['contact_width']:.1f}"
                      f" cm; {text})")
        print(f"{path}: {good} of {len(records)} best grasps straddle an object")
    return 0


if __name__ == "__main__":
    sys.exit(main())
