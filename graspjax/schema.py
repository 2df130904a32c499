"""Every output's columns and labels in one place, importing neither JAX nor the simulator, so
that reports and tables (`report/`) read a run's files without loading MJX.

- `attempts.csv`: one row per attempt (`batch/rows.py` builds them from a chunk's records),
  its columns `ATTEMPT_COLUMNS` in order (`attempt_columns`); rows sorted by `SORT`
  (`sort_attempts`).
- `rounds.csv`: one row per settled Setup 2/3 layout, `ROUND_COLUMNS`; its density is
  `LAYOUT_COLUMNS`.
- `timings.csv`: one row per chunk, `TIMINGS_COLUMNS`.
- `planes.csv.gz` (`graspjax planes`): one row per grid point and world, `PLANES_COLUMNS`.
- `graspjax bench ... --out FILE.json`: one record per benchmark, `BENCH_FIELDS[what]` and then
  `PROVENANCE_FIELDS`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from graspjax.codes import Reason, Surface

# attempts.csv, column by column in file order ("{k}": one column per re-alignment allowed,
# k = 1 ... `config.MAX_REORIENTATIONS`; "cfg.{key}": one per grid key and per value the run
# changed from the defaults, after the others). docs/outputs.md is `outputs_markdown()`.
ATTEMPT_COLUMNS = {
    "run_id": "the run's id (settings that determine the rows, hashed; `outputs.run_id`)",
    "point": "grid point of a sweep (0 in a run)",
    "method": "the grasp method (`paper`, `highest-pca`, `antipodal`)",
    "setup": "the paper's setup: 1 single, 2 grouped, 3 dense clutter",
    "object": "the object the attempt is credited to (ground truth: the one its target point "
              "lies on; \"\" for none)",
    "trial": "trial of the object (Setup 1) or the round (Setups 2, 3)",
    "round": "the round (Setups 2, 3; empty in Setup 1); joins rounds.csv",
    "attempt": "attempt number in the world (0 first; -1: an object that got no attempt)",
    "seed": "the seed the world's layout and noise derive from",
    "success": "1 if the credited object was lifted and held, else 0",
    "outcome": "what the executed grasp did (`codes.Outcome`; NOT_EXECUTED without a grasp)",
    "reason": "the one reason of the outcome, as a label (`codes.Reason`)",
    "reorientations": "re-alignments made before the grasp",
    "lifted_object": "the object lifted (\"\" for none; may differ from the target)",
    "chunk": "the chunk of worlds that played it (volatile: depends on --batch)",
    "objects": "the world's objects (letters)",
    "reason_code": "`reason` as its integer code (-1: not attempted)",
    "grasp_found": "1 if a view held a grasp",
    "first_view_grasp": "1 if the first view already held one (no re-alignment needed)",
    "rescued": "1 if it succeeded with a grasp found only after a re-alignment",
    "detect_reason": "the detection's reason in the last view searched (`GraspReason` name)",
    "align_reason": "the last re-alignment's reason (`AlignReason` name; \"\" if none tried)",
    "grasp_object": "the object under the planned grasp centre (ground truth; \"\" for none)",
    "segment_precision": "share of the target surface the method took that lies on the "
                         "credited object (ground truth; empty: none)",
    "segment_recall": "share of the credited object's visible pixels in that surface",
    "target_touching": "1.0 if the target touched another object when the robot looked "
                       "(ground truth, never seen by the method)",
    "target_resting": "1.0 if it rested on another object",
    "target_covered": "1.0 if another object rested on it",
    "target_gap_m": "its nearest outline distance to another object seen from above (m; "
                    "negative: overlapping)",
    "finger_clearance_m": "free space around the open fingers at the executed grasp pose to "
                          "anything but the target and the table (m; negative: a finger inside a "
                          "part)",
    "rise_m": "how far the target rose after the hold (m; empty if not executed)",
    "jaw_opening_m": "the jaws' opening after closing (m; empty if not executed)",
    **{f"grasp_{name}_{axis}": f"the planned grasp's {what}, {axis} (world frame{unit})"
       for name, what, unit in (("tcp", "point between the finger tips", ", m"),
                                ("approach", "approach direction", ""),
                                ("closing", "closing axis", ""))
       for axis in "xyz"},
    "realign{k}_surface": "what re-alignment k's chosen plane lies on (ground truth: "
                          "`SURFACE_LABELS`; \"\" if not taken)",
    "realign{k}_on_target": "share of that plane's inliers on the target (ground truth)",
    "realign{k}_normal_error_deg": "its normal against the target's nearest true face (deg)",
    "realign{k}_view_tilt_deg": "the re-aligned view's tilt from straight down (deg)",
    "cfg.{key}": "the value of configuration key `key` at the row's grid point",
}
SORT = ["point", "setup", "trial", "attempt_order", "object"]  # trial: the round in Setups 2, 3
WORLD_MAJOR = ["setup", "trial", "attempt_order", "object", "point"]  # each attempt's grid points
# side by side: how a paired sweep's rows compress best (`report.files.keep_attempts`)
STUDY_OMITS = ("rise_m", "jaw_opening_m", "finger_clearance_m", "target_gap_m", "segment_precision",
               "segment_recall", *(f"grasp_{name}_{axis}" for name in ("tcp", "approach", "closing")
                                   for axis in "xyz"))  # the measured columns a committed
# parameter study or comparison of methods leaves out of its kept rows (`keep_attempts(omit=)`):
# the executed grasp's pose and measurements, the target's gap and its segmentation, which
# neither its report nor `experiments/realign_*.py` reads; its command gives them back
LAYOUT_COLUMNS = ("touching_fraction", "near_fraction", "stacked", "min_face_gap_m",
                  "spread_m")  # rounds.csv:
# the settled layout's statistics (`rows.round_rows`)
ROUND_COLUMNS = {  # rounds.csv, in file order
    "point": "grid point", "method": "the grasp method", "seed": "the layout's seed",
    "setup": "2 or 3", "round": "the round (the trial of every object in it)",
    "objects": "the round's objects (letters)",
    "touching_fraction": "objects in contact with another, once the layout settled",
    "near_fraction": "objects whose outline seen from above lies within 2 mm of another's",
    "stacked": "objects resting on another",
    "min_face_gap_m": "median over objects of the nearest outline-to-outline distance (m; 0 "
                      "touching)",
    "spread_m": "largest distance between two objects' origins seen from above (m)",
    "attempts": "attempts made in the round", "successes": "of them successful",
    "grasp_success_rate": "successes / attempts",
    "objects_placed": "objects in the round", "objects_removed": "objects lifted out",
    "declutter_rate": "objects_removed / objects_placed",
    "end": "how the round ended (`once each`; continued rounds: `empty`, `stuck`, `limit`)",
}
_TIMINGS_MEANING = {
    "chunk": "the chunk's index in the run",
    "group": "its group of worlds (one scene and static configuration: one program)",
    "scene": "the scene's object letters",
    "worlds": "worlds played (padding excluded)",
    "batch": "the program's batch size (per call, all devices)",
    "attempts": "attempts made",
    "program": "traced here, by a worker process, or loaded from the exported store",
    "executable": "its device's executable: compiled here, loaded (compiled by an earlier run, "
                  "another process or another device: `runtime.executables`), or cached (read "
                  "from JAX's compilation cache)",
    "trace_s": "seconds tracing the program (the group's first chunk only)",
    "compile_s": "seconds compiling it (the group's first chunk only)",
    "started_s": "when the chunk started playing, seconds after the run began",
    "wall_s": "seconds it played",
    "peak_gib": "the most memory in use so far on its device (GiB; empty where not reported)",
    "device": "the local device that played it",
    "process": "the helper process that played it (0: the run's own)",
}
TIMINGS_COLUMNS = tuple(_TIMINGS_MEANING)
_PLANES_MEANING = {
    "point": "grid point",
    "setup": "the world's setup",
    "trial": "its trial (Setups 2, 3: the round)",
    "object": "its object (Setups 2, 3: the round's objects)",
    "target": "the object the first view's target point lies on (ground truth; \"\" if none)",
    "first_view_grasp": "the first view already holds a grasp (such a view does not re-align)",
    "plane_found": "the plane scoring found a plane",
    "surface": "what most of the chosen plane's inliers lie on (`SURFACE_LABELS`; ground truth)",
    "on_target": "share of its inliers on the target (ground truth)",
    "normal_error_deg": "its normal against the target's nearest true face (deg)",
    "view_tilt_deg": "the re-aligned view's tilt from straight down (deg)",
}
PLANES_COLUMNS = tuple(_PLANES_MEANING)
_PROFILE_MEANING = {  # `graspjax bench pipeline --profile DIR`: DIR/kernels.csv
    "module": "the compiled program (`jit_start_round`, `jit_attempt`)",
    "op": "the compiled operation that launched the kernels (a fusion, a library call, a CUDA "
          "graph's `command_buffer_N`)",
    "kernel": "the name of its first kernel",
    "calls": "kernels it launched in the profiled round",
    "seconds": "their device time",
    "file": "the source file its HLO metadata names (empty: none, e.g. a CUDA graph)",
    "function": "the function, or in an exported program the name scope, the metadata names",
    "line": "the source line (0: none)",
}
PROFILE_COLUMNS = tuple(_PROFILE_MEANING)
PROVENANCE_FIELDS = (
    "versions",  # package -> version (graspjax's from graspjax/version.py, jax, mujoco, ...)
    "code",  # digest of graspjax's sources; git commit and changes when run from a checkout
    "python",  # Python's version
    "devices",  # every local device, "platform:kind:id"
    "device",  # the first device's platform and kind, and the device count
    "cpu",  # the host CPU's model (XLA:CPU compiles for its instruction set)
    "host",  # the host's name
    "command",  # the graspjax command as typed
)
PERCEPTION_KERNELS = ("detect+align", "detect", "align", "target", "view")  # timed batched
_WORKLOAD = (
    "batch",  # images per batched call
    "width", "height",  # image size (pixels)
    "unique_scenes",  # distinct random scenes the batch cycles through
    "repeats",  # timed calls (the median is reported)
)
BENCH_FIELDS = {
    "perception": (  # `bench.perception_benchmark`: kernels on simulated 160 x 120 views
        *_WORKLOAD,
        *(f"{kernel}_{measure}" for kernel in PERCEPTION_KERNELS
          for measure in ("compile_s", "batch_s", "images_per_s")),  # s, s per call, images/s
        "single_compile_s", "single_latency_ms",  # one image, detect+align
        "grasp_found_fraction",  # share of the scenes where `detect_grasp` finds a grasp
    ),
    "detect": (  # `bench.detect_benchmark`: `graspjax detect`'s kernel on real-looking images
        *_WORKLOAD,
        "detect_width", "support_width",  # working resolutions (pixels across)
        "batch_compile_s", "batch_s", "images_per_s",  # the batch: compile, s per call, rate
        "single_compile_s", "single_latency_ms", "single_latency_p90_ms",  # one image, NumPy in
        "grasp_found_fraction",  # share of the scenes with a grasp
        "profile", "profiled_call", "profiled_s", "profile_summary",  # --profile: one more
        # call traced, as pipeline's: "single" (one image, a CPU's) or "batch"
    ),
    "physics": (  # `bench.physics_benchmark`: one scene's worlds settling and grasping
        "scene", "setup", "batch",  # object letters, setup, worlds
        "build_s", "compile_s",  # scene build, physics compile (s)
        "settle_world_steps_per_s", "execute_world_steps_per_s", "execute_s",
        "grasp_success_fraction",  # share of blind top-down grasps that lifted
        "render_compile_s", "render_images_per_s", "render_resolution", "sensor",  # depth images
        "ncon",  # contact slots of the scene's model
    ),
    "pipeline": (  # `bench.pipeline_benchmark`: attempts end to end
        "objects", "setups", "trials", "batch",
        "attempts", "success_rate",
        "trace_s", "compile_s", "run_s",  # tracing, compiling, then running every chunk (s)
        "attempts_per_s",
        "deterministic",  # XLA's deterministic GPU ops were on
        "profile", "profiled_s", "profile_summary",  # --profile: its folder, the seconds
        # traced and the printed summary (`bench_profile`); None without it
    ),
    "finish": (  # `bench.finish_benchmark`: a run's end after its last chunk
        "source",  # the finished run whose rows are repeated
        "rows", "chunks",
        "files_s",  # attempts.csv, .parquet, rounds.csv, timings.csv assembled and written (s)
        "report_s",  # tables and figures from the rows in memory (s)
        "after_last_chunk_s",  # the two together (s)
    ),
}


def attempt_columns(reorientations: int, keys: list[str]) -> list[str]:
    """attempts.csv's header: `ATTEMPT_COLUMNS` with `reorientations` re-alignments' columns
    and the `cfg.` columns of `keys`."""
    names = []
    for name in ATTEMPT_COLUMNS:
        if "{k}" in name:
            names += [name.format(k=k) for k in range(1, reorientations + 1)]
        elif name == "cfg.{key}":
            names += [f"cfg.{key}" for key in keys]
        else:
            names.append(name)
    return names


# `graspjax detect`'s results.csv, column by column in file order: one row per ranked grasp of
# each image (one saying why where none passed); positions and axes in the camera frame (OpenCV:
# x right, y down, z forward; metres); pixels in the file's own
DETECT_COLUMNS = {
    "image": "the depth file",
    "found": "whether a grasp passed every check",
    "reason": "why none did (`GraspReason` name; FOUND when one did)",
    "rank": "the grasp's rank among the image's grasps (1: best)",
    "score": "its score: free height below the tips (capped at 1 cm) plus width margin "
             "(capped at a quarter of the opening) less the distance from the part's centre "
             "in half-openings",
    "target": "which target (surface) of the image it was found on, 1: the nearest",
    "x": "grasp centre G on the target's top surface, camera frame (m)", "y": "", "z": "",
    "axis_x": "the closing axis, a unit vector in the camera frame", "axis_y": "", "axis_z": "",
    "approach_x": "the approach, into the scene (the view's axis)", "approach_y": "",
    "approach_z": "",
    "width": "the band's width across the closing axis (m)",
    "contact_width": "the width the jaws close on at the finger tips' level (m)",
    "grasp_depth": "how far the jaws reach below G along the approach (m)",
    "clearance": "free height below the finger tips under the fingers' footprints (m)",
    "landing_fall": "how far below G the highest surface under either finger lies, where the "
                    "fingers land (m; -inf: nothing known there)",
    "u": "G's pixel column in the file", "v": "its row",
    "target_u": "the target's nearest point, pixel column", "target_v": "its row",
    "target_height": "the target's height above the support plane (m; empty: no plane)",
    "targets_tried": "targets tried (the reported one is the best grasp's, else the last)",
    "view": "camera (the image as taken) or virtual (re-projected to look straight down)",
    "support": "the support plane's fit (`SupportReason` name)",
    "support_nx": "its normal in the camera frame", "support_ny": "", "support_nz": "",
    "support_distance": "its distance from the camera (m)",
    "support_tilt_deg": "the camera's tilt against it (deg)",
    "support_inlier_fraction": "share of the workspace's pixels on it",
    "alignment": "the re-alignment's plane (`AlignReason` name)",
    "align_nx": "its normal in the camera frame", "align_ny": "", "align_nz": "",
    "load_ms": "reading the file (ms)", "compute_ms": "detecting (ms)",
    "method": "the grasp method (paper, highest-pca, antipodal)",
    "placed_by": "contour where the contour search placed the grasp, else the method",
    "pose_{i}{j}": "the grasp as a 4x4 pose, gripper frame to camera frame, row i, column j "
                   "(columns: closing axis, approach x closing axis, approach; translation G)",
    "pose_world_{i}{j}": "the same pose in the world frame, gripper to world (with "
                         "--camera-pose: the camera's pose times pose; else empty)",
}


def detect_columns() -> list[str]:
    """results.csv's columns in file order (`DETECT_COLUMNS`, the pose's 16 spelled out)."""
    return [key.format(i=i, j=j) for key in DETECT_COLUMNS
            for i, j in ([(i, j) for i in range(4) for j in range(4)] if "{i}" in key else [(0, 0)])]


def outputs_markdown() -> str:
    """docs/outputs.md: every column of the files a run writes, from this module."""
    def table(columns) -> str:
        return "| column | meaning |\n|---|---|\n" + "".join(
            f"| `{name}` | {text} |\n" for name, text in columns)

    def described(names, comments) -> list[tuple[str, str]]:
        return [(name, comments.get(name, "")) for name in names]

    return "\n".join([
        "# What a run writes, column by column",
        "",
        "Generated from `graspjax/schema.py` (`outputs_markdown`); `tests/test_schema.py` keeps "
        "the two alike.",
        "",
        "## attempts.csv (and attempts.parquet): one row per attempt",
        "",
        "Sorted by point, setup, trial (the round in Setups 2, 3), attempt (objects that got "
        "none last), object. `{k}`: one column per re-alignment allowed (1-3); `cfg.{key}`: "
        "one per grid key and per value the run changed from the defaults.",
        "",
        table(ATTEMPT_COLUMNS.items()),
        "## rounds.csv: one row per settled Setup 2/3 round",
        "",
        table(ROUND_COLUMNS.items()),
        "## timings.csv: one row per chunk",
        "",
        table(described(TIMINGS_COLUMNS, _TIMINGS_MEANING)),
        "## planes.csv.gz (`graspjax planes`): one row per grid point and world",
        "",
        table(described(PLANES_COLUMNS, _PLANES_MEANING)),
        "## results.csv (`graspjax detect`): one row per ranked grasp of each image",
        "",
        "One row saying why where no grasp passed. Positions and axes in the camera frame "
        "(OpenCV: x right, y down, z forward; metres); pixels in the file's own. "
        "`pose_{i}{j}`, `pose_world_{i}{j}`: sixteen columns each, row by row.",
        "",
        table(DETECT_COLUMNS.items()),
    ])


REASON_LABELS = np.array([Reason(r).label if r in Reason._value2member_map_ else ""
                          for r in range(max(Reason) + 1)], dtype=object)  # Reason -> label
SURFACE_LABELS = np.array([s.name.lower().replace("_", " ") if s != Surface.NONE else ""
                           for s in sorted(Surface)], dtype=object)  # index: Surface + 1


def attempt_order(frame: pd.DataFrame, order: list[str] = SORT) -> np.ndarray:
    """The permutation (n,) that puts attempt rows in the canonical order: point, setup, trial
    (the round in Setups 2, 3), attempt (unattempted last), object (missing last); stable.
    `order`: these keys in another order (`WORLD_MAJOR`)."""
    keys = {"point": frame["point"], "setup": frame["setup"], "trial": frame["trial"],
            "attempt_order": frame["attempt"].where(frame["attempt"] >= 0, 99),
            "object": frame["object"]}
    columns = []
    for name in order:
        codes, _ = pd.factorize(keys[name], sort=True)  # missing values: -1
        columns.append(np.where(codes < 0, np.iinfo(codes.dtype).max, codes))
    return np.lexsort(columns[::-1])  # the last key is lexsort's first


def sort_attempts(frame: pd.DataFrame) -> pd.DataFrame:
    """Rows in the canonical order (`attempt_order`)."""
    return frame.take(attempt_order(frame)).reset_index(drop=True)


def outcome_label(frame: pd.DataFrame) -> pd.Series:
    """One short label per attempt row: its outcome when executed, else why no grasp was
    executed ("no grasp: NO_ROOM", "align: NO_PLANE", "no target", "not attempted: ...")."""
    label = frame["reason"].where(frame["outcome"] == "NOT_EXECUTED", frame["outcome"])
    return label.str.replace("detection: ", "no grasp: ").str.replace("alignment: ", "align: ")
