"""`graspjax detect` judged per source on real captures from six public sources, the images
kept outside the repository.

    python experiments/real_depth_sources.py extract MIRROR DEV
    python experiments/real_depth_sources.py detect DEV RESULTS [-- graspjax detect arguments]
    python experiments/real_depth_sources.py judge DEV RESULTS [RESULTS2 ...] [--csv FILE] > table.md

`extract` writes every capture as DEV/<source>/<case>.npz (`depth` metres (H, W), 0 = none;
`K` (3, 3); `labels` (H, W) int16 where the source segments its objects: 0 unknown or no
depth, 1 the support or the rest of the scene, 2, 3, ... one per object) and DEV/cases.json
(source, origin, licence, sensor, workspace box). MIRROR holds git clones (bare or
not) at `<owner>+<name>/repo` of PointCloudLibrary/data,
PointCloudLibrary/pcl and NVlabs/6dof-graspnet; the gqcnn, sd-maskrcnn and
UnseenObjectClustering captures come from `../shared/real_depth/`. None of the held-out captures
(docs/real_depth.md) is among them.

`detect` runs `graspjax detect --top 2` over each source (one call per image size and workspace
box) into RESULTS/<source>/<group>/results.json. `judge` prints, per source and for each
RESULTS folder, the best grasps found and how many straddle an object: by the geometry of the
raw depth (`judge_real_depth.judge`, its support plane within `JUDGE_TILT_DEG` of the optical
axis) and, where the source has object labels, by them: the grasp centre's pixel on an
object's label, and each finger, brought down along the approach at its place, meeting none of
that object's seen points above the grasp depth (`label_verdict`); and whether the answer is
right by the labels (a grasp that straddles, or none where no object is narrower than the open
jaws). Wilson 95 % intervals; `--csv` also
writes every capture's verdicts. `results/real_depth/sources/README.md` gives the commands.
"""

from __future__ import annotations

import argparse
import io
import json
import subprocess
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from judge_real_depth import FINGER_OFFSET, column_top, judge, unproject  # noqa: E402

from graspjax.errors import InputError  # noqa: E402
from graspjax.imagefiles.clouds import read_pcd_points  # noqa: E402
from graspjax.imagefiles.readers import fit_intrinsics, load_intrinsics  # noqa: E402
from graspjax.stats import wilson  # noqa: E402

SHARED = Path(__file__).resolve().parents[1].parent / "shared" / "real_depth"
JUDGE_TILT_DEG = 70.0  # the judge's support plane: the largest within this of the optical axis
# (the mOSD and 6dof-graspnet cameras look 45-60 degrees down at their tables)
GQCNN = (("primesense_single", "primesense.intr", (60, 20, 600, 350)),
         ("primesense_clutter", "primesense.intr", (60, 20, 600, 350)),
         ("phoxi_clutter", "phoxi.intr", (70, 50, 470, 320)))  # the boxes of SHARED/README.md
SIXDOF = ("blue_mug", "cheezit", "cylinder", "green_bowl", "mustard", "pepper", "red_mug",
          "sugar", "white_bowl", "white_mug")
PCL_TEST = ("test/grabber_sequences/pcd/frame_20121214T142255.814212.pcd",
            "test/table_scene_mug_stereo_textured.pcd")
LICENCES = {
    "gqcnn": "BerkeleyAutomation/gqcnn: research and not-for-profit use (SHARED/LICENSE)",
    "sdmaskrcnn": "BerkeleyAutomation/sd-maskrcnn: MIT (added after the files left HEAD)",
    "uoc": "NVlabs/UnseenObjectClustering: NVIDIA Source Code License, non-commercial",
    "mosd": "PointCloudLibrary/data mOSD: the Object Segmentation Database's licence",
    "sixdof": "NVlabs/6dof-graspnet: MIT",
    "pcl": "PointCloudLibrary/pcl: BSD-3-Clause",
}


def _git_show(repo: Path, path: str) -> bytes:
    return subprocess.run(["git", "-C", str(repo), "show", f"HEAD:{path}"], check=True,
                          capture_output=True).stdout


def _git_paths(repo: Path, folder: str) -> list[str]:
    out = subprocess.run(["git", "-C", str(repo), "ls-tree", "-r", "--name-only", "HEAD",
                          folder], check=True, capture_output=True, text=True).stdout
    return sorted(out.split(), key=lambda p: (len(p), p))


def _cloud_case(raw: bytes, scratch: Path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """Depth, K and (mOSD's) merged labels of an organised .pcd's bytes."""
    scratch.write_bytes(raw)
    points = read_pcd_points(scratch)
    xyz = np.stack([points[a].astype(np.float32) for a in "xyz"], -1)
    depth = np.nan_to_num(xyz[..., 2], nan=0.0)
    labels = None
    if "label" in points.dtype.names:  # mOSD: 1-9 the table, 10 k + j part j of object k - 1
        raw_labels = points["label"].astype(np.int64)
        labels = np.where(raw_labels >= 20, raw_labels // 10, np.minimum(raw_labels, 1))
        labels = np.where(depth > 0, labels, 0).astype(np.int16)
    return depth, fit_intrinsics(xyz, "cloud"), labels


def _sixdof_case(raw: bytes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Depth, K and the object's label: the pixels its segmented points (`smoothed_object_pc`,
    camera frame) project to, within 1 cm of the depth seen there."""
    data = np.load(io.BytesIO(raw), allow_pickle=True, encoding="latin1").item()
    depth = np.nan_to_num(data["depth"].astype(np.float32))
    k = np.asarray(data["intrinsics_matrix"], np.float64)
    points = np.asarray(data["smoothed_object_pc"], np.float64)
    u = np.round(k[0, 0] * points[:, 0] / points[:, 2] + k[0, 2]).astype(int)
    v = np.round(k[1, 1] * points[:, 1] / points[:, 2] + k[1, 2]).astype(int)
    inside = (u >= 0) & (u < depth.shape[1]) & (v >= 0) & (v < depth.shape[0])
    labels = np.where(depth > 0, 1, 0).astype(np.int16)
    u, v, z = u[inside], v[inside], points[inside, 2]
    near = np.abs(depth[v, u] - z) < 0.01
    labels[v[near], u[near]] = 2
    return depth, k, labels


def extract(mirror: Path, dev: Path) -> int:
    cases = []

    def keep(source, name, depth, k, labels, origin, sensor, roi=None):
        folder = dev / source
        folder.mkdir(parents=True, exist_ok=True)
        arrays = {"depth": depth.astype(np.float32), "K": k}
        if labels is not None:
            arrays["labels"] = labels
        np.savez_compressed(folder / f"{name}.npz", **arrays)
        cases.append({"source": source, "name": name, "file": f"{source}/{name}.npz",
                      "origin": origin, "licence": LICENCES[source], "sensor": sensor,
                      "size": [int(depth.shape[1]), int(depth.shape[0])],
                      "roi": None if roi is None else list(roi), "labels": labels is not None})

    for folder, intr, roi in GQCNN:
        info = load_intrinsics(SHARED / intr)
        k = np.array([[info["fx"], 0, info["cx"]], [0, info["fy"], info["cy"]], [0, 0, 1]])
        for path in sorted((SHARED / folder).glob("depth_*.npy")):
            keep("gqcnn", f"{folder}_{path.stem}", np.load(path).squeeze(), k, None,
                 f"gqcnn data/examples ({folder}/{path.name})", folder.split("_")[0], roi)
    more = json.loads((SHARED / "more" / "cases.json").read_text())["cases"]
    with np.load(SHARED / "more" / "more.npz") as archive:
        for case in more:
            k = np.array([[case["fx"], 0, case["cx"]], [0, case["fy"], case["cy"]], [0, 0, 1]])
            source = "sdmaskrcnn" if case["name"].startswith("sdm") else "uoc"
            keep(source, case["name"], archive[case["key"]], k, None,
                 f"{case['source_repo']} {case['source_path']}", case["sensor"], case["roi"])
    scratch = dev / "scratch.pcd"
    repo = mirror / "PointCloudLibrary+data" / "repo"
    for path in _git_paths(repo, "segmentation/mOSD"):
        if path.endswith(".pcd"):
            try:
                depth, k, labels = _cloud_case(_git_show(repo, path), scratch)
            except InputError as exc:  # one of them is stored unorganised
                print(f"skipped {path}: {str(exc).split(': ', 1)[1]}", file=sys.stderr)
                continue
            keep("mosd", Path(path).stem, depth, k, labels, f"PointCloudLibrary/data {path}",
                 "Kinect")
    repo = mirror / "PointCloudLibrary+pcl" / "repo"
    for path, sensor in zip(PCL_TEST, ("Kinect", "PR2 stereo"), strict=True):
        depth, k, _ = _cloud_case(_git_show(repo, path), scratch)
        keep("pcl", Path(path).stem, depth, k, None, f"PointCloudLibrary/pcl {path}", sensor)
    scratch.unlink(missing_ok=True)
    repo = mirror / "NVlabs+6dof-graspnet" / "repo"
    for name in SIXDOF:
        depth, k, labels = _sixdof_case(_git_show(repo, f"demo/data/{name}.npy"))
        keep("sixdof", name, depth, k, labels, f"NVlabs/6dof-graspnet demo/data/{name}.npy",
             "RealSense")
    (dev / "cases.json").write_text(json.dumps({"cases": cases}, indent=1) + "\n")
    counts = defaultdict(int)
    for case in cases:
        counts[case["source"]] += 1
    print(f"{len(cases)} captures:", ", ".join(f"{s} {n}" for s, n in counts.items()))
    return 0


def detect(dev: Path, results: Path, extra: list[str]) -> int:
    cases = json.loads((dev / "cases.json").read_text())["cases"]
    groups = defaultdict(list)
    for case in cases:
        groups[(case["source"], tuple(case["size"]), tuple(case["roi"] or ()))].append(case)
    for (source, size, roi), members in groups.items():
        name = f"{size[0]}x{size[1]}" + (f"_roi{'_'.join(map(str, roi))}" if roi else "")
        out = results / source / name
        out.parent.mkdir(parents=True, exist_ok=True)
        command = [sys.executable, "-m", "graspjax.cli", "detect",
                   *[str(dev / c["file"]) for c in members], "--top", "2", "--quiet",
                   "--out", str(out), *(["--roi", ",".join(map(str, roi))] if roi else []),
                   *[a for a in extra if a != "--"]]
        code = subprocess.run(command, stdout=subprocess.DEVNULL).returncode
        print(f"{source} {name}: {len(members)} images, exit {code}", file=sys.stderr)
        if code:
            return code
    return 0


#: The labels judge's finger column: a finger place stands on the object when one of the
#: object's seen points lies within this of the line along the approach through the place (m;
#: the depth image's pixel spacing at 0.5-1 m is 1-2 mm)
LABEL_COLUMN = 0.002


def label_verdict(rec: dict, candidate: dict, depth: np.ndarray, labels: np.ndarray,
                  column: float = LABEL_COLUMN) -> bool:
    """The best grasp straddles an object by its labels: its centre's pixel is on an object,
    and each finger, brought down along the grasp's approach at its place (`FINGER_OFFSET`
    beyond the band's half width), meets none of that object's seen points (within `column`
    of its line) less than the grasp depth below the centre. Read in 3D, not at the place's
    pixel: seen obliquely, a place in front of the object's near face projects onto that
    face, though the finger comes down beside it."""
    cam = rec["camera"]
    centre, axis = np.asarray(candidate["position"]), np.asarray(candidate["closing_axis"])
    approach = np.asarray(candidate["pose"])[:3, 2]  # the grasp frame's z, camera frame
    u = int(round(cam["fx"] * centre[0] / centre[2] + cam["cx"]))
    v = int(round(cam["fy"] * centre[1] / centre[2] + cam["cy"]))
    if not (0 <= v < labels.shape[0] and 0 <= u < labels.shape[1]) or labels[v, u] < 2:
        return False
    rows, cols = np.nonzero((labels == labels[v, u]) & (depth > 0) & np.isfinite(depth))
    points = unproject(cols, rows, depth[rows, cols].astype(np.float64), cam)
    for side in (1, -1):
        place = centre + side * axis * (candidate["width"] / 2 + FINGER_OFFSET)
        # the object's highest seen point in the finger's column, above the centre's level
        # (a plane through the place facing against the approach)
        top = column_top(points, place, -approach, approach @ place, column)
        if top is not None and -top < candidate["depth"]:
            return False
    return True


def narrowest_object(depth: np.ndarray, k: np.ndarray, labels: np.ndarray) -> float:
    """The narrowest labelled object's width (m): per object, the least extent over 180
    directions of its seen points projected onto the support (the plane fitted by least squares
    to the pixels labelled 1). Seen from one side, an object's far side is hidden: its top and
    near side still give the width across it."""
    v, u = np.nonzero(depth > 0)
    z = depth[v, u].astype(np.float64)
    points = np.stack([(u - k[0, 2]) * z / k[0, 0], (v - k[1, 2]) * z / k[1, 1], z], -1)
    which = labels[v, u]
    support = points[which == 1]
    centre = support.mean(0)
    normal = np.linalg.svd(support - centre, full_matrices=False)[2][2]
    first = np.cross(normal, [1.0, 0.0, 0.0])
    first /= np.linalg.norm(first)
    plane = np.stack([first, np.cross(normal, first)], -1)  # (3, 2) the support's axes
    angles = np.linspace(0.0, np.pi, 180, endpoint=False)
    directions = np.stack([np.cos(angles), np.sin(angles)])  # (2, 180)
    widths = [np.min(np.ptp(points[which == label] @ plane @ directions, axis=0))
              for label in np.unique(which[which >= 2]) if np.sum(which == label) >= 50]
    return float(min(widths, default=np.inf))


def verdicts(dev: Path, folders: list[Path]) -> list[dict]:
    """One row per capture and RESULTS folder: whether a best grasp was found, whether it
    straddles an object by the geometry and by the labels, and whether the answer is right by
    the labels (a grasp that straddles, or none where no object is narrower than the open jaws
    less their clearance); None where the capture has no labels."""
    from graspjax.config import Config

    fits = Config().gripper.opening - 2 * Config().detect.clearance  # the widest part taken
    cases = {str((dev / c["file"]).resolve()): c
             for c in json.loads((dev / "cases.json").read_text())["cases"]}
    narrow = {}
    for path, case in cases.items():
        if case["labels"]:
            with np.load(path) as data:
                narrow[path] = narrowest_object(data["depth"], data["K"], data["labels"]) <= fits
    rows = []
    for folder in folders:
        for path in sorted(folder.glob("*/*/results.json")):
            for rec in json.loads(path.read_text()):
                image = str(Path(rec["image"]).resolve())
                case = cases[image]
                best = rec["candidates"][0] if rec["candidates"] else None
                row = {"run": folder.name, "source": case["source"], "case": case["name"],
                       "reason": rec["reason"], "found": best is not None,
                       "geometry": best is not None
                       and bool(judge(rec, best, tilt_deg=JUDGE_TILT_DEG)[0]),
                       "narrow_part": narrow.get(image), "labels": None, "right": None}
                if image in narrow:
                    with np.load(image) as data:
                        row["labels"] = best is not None and label_verdict(
                            rec, best, data["depth"], data["labels"])
                    row["right"] = row["labels"] or (best is None and not narrow[image])
                rows.append(row)
    return rows


#: The sources graspjax detect's rules were developed on; the others it has never been run on
#: before they joined this set, so each of them is a source left out of its development.
DEVELOPED_ON = ("gqcnn", "sdmaskrcnn", "uoc")


def table(rows: list[dict]) -> str:
    """The markdown table of `verdicts`' rows: one line per source and run, the sources the
    detector was developed on first, then those it was not, then each group's total."""
    runs = list(dict.fromkeys(r["run"] for r in rows))
    present = list(dict.fromkeys(r["source"] for r in rows))
    developed = [s for s in DEVELOPED_ON if s in present]
    unseen = [s for s in present if s not in DEVELOPED_ON]
    groups = [*[(s, (s,)) for s in developed], ("developed on, all", tuple(developed)),
              *[(s, (s,)) for s in unseen], ("never developed on, all", tuple(unseen))]
    lines = ["| source | run | images | found | straddles (geometry) | with a part the jaws "
             "take (labels) | straddles (labels) | right (labels) |", "|---|---|---|---|---|---|---|---|"]
    for name, sources in groups:
        for run in runs:
            these = [r for r in rows if r["run"] == run and r["source"] in sources]
            judged = [r for r in these if r["labels"] is not None]
            labelled = (f"{sum(r['narrow_part'] for r in judged)} | "
                        f"{_rate(sum(r['labels'] for r in judged), len(judged))} | "
                        f"{_rate(sum(r['right'] for r in judged), len(judged))}"
                        if judged else "- | - | -")
            lines.append(f"| {name} | {run} | {len(these)} | {sum(r['found'] for r in these)} | "
                         f"{_rate(sum(r['geometry'] for r in these), len(these))} | {labelled} |")
    return "\n".join(lines)


def _rate(k: int, n: int) -> str:
    low, high = wilson(k, n)
    return f"{k}/{n} ({100 * low:.0f}-{100 * high:.0f} %)"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="step", required=True)
    p = sub.add_parser("extract")
    p.add_argument("mirror", type=Path)
    p.add_argument("dev", type=Path)
    p = sub.add_parser("detect")
    p.add_argument("dev", type=Path)
    p.add_argument("results", type=Path)
    p.add_argument("extra", nargs=argparse.REMAINDER)
    p = sub.add_parser("judge")
    p.add_argument("dev", type=Path)
    p.add_argument("results", type=Path, nargs="+")
    p.add_argument("--csv", type=Path, help="also write every capture's verdicts here")
    args = parser.parse_args()
    if args.step == "extract":
        return extract(args.mirror, args.dev)
    if args.step == "detect":
        return detect(args.dev, args.results, args.extra)
    rows = verdicts(args.dev, args.results)
    if args.csv:
        import pandas as pd

        pd.DataFrame(rows).to_csv(args.csv, index=False)
    print(table(rows))
    return 0


if __name__ == "__main__":
    sys.exit(main())
