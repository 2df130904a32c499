"""Every output's columns and labels in one place, importing neither JAX nor the simulator, so
that reports and tables (`report/`) read a run's files without loading MJX.

- `attempts.csv`: one row per attempt (`batch/rows.py` builds them from a chunk's records);
  `FIRST_COLUMNS` lead, the record's columns follow, then a `cfg.<key>` column per grid key
  and per value the run changed; rows sorted by `SORT` (`sort_attempts`).
- `rounds.csv`: one row per settled Setup 2/3 layout; its density is `LAYOUT_COLUMNS`.
- `timings.csv`: one row per chunk, `TIMINGS_COLUMNS`.
- `planes.csv.gz` (`graspjax planes`): one row per grid point and world, `PLANES_COLUMNS`.
- `graspjax bench ... --out FILE.json`: one record per benchmark, `BENCH_FIELDS[what]` and then
  `PROVENANCE_FIELDS`.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from graspjax.codes import Reason, Surface

FIRST_COLUMNS = ["run_id", "point", "method", "setup", "object", "trial", "round", "attempt",
                 "seed", "success", "outcome", "reason", "reorientations", "lifted_object"]
SORT = ["point", "setup", "trial", "attempt_order", "object"]  # trial: the round in Setups 2, 3
LAYOUT_COLUMNS = ("touching_fraction", "near_fraction", "stacked", "min_face_gap_m",
                  "spread_m")  # rounds.csv:
# the settled layout's statistics (`rows.round_rows`)
TIMINGS_COLUMNS = (
    "chunk",  # the chunk's index in the run
    "group",  # its group of worlds (one scene and static configuration: one program)
    "scene",  # the scene's object letters
    "worlds",  # worlds played (padding excluded)
    "batch",  # the program's batch size (per call, all devices)
    "attempts",  # attempts made
    "program",  # traced here, by a worker process, or loaded from the exported store
    "trace_s",  # seconds tracing the program (the group's first chunk only)
    "compile_s",  # seconds compiling it (the group's first chunk only)
    "started_s",  # when the chunk started playing, seconds after the run began
    "wall_s",  # seconds it played
    "peak_gib",  # the most memory in use so far on its device (GiB; empty where not reported)
    "device",  # the local device that played it
    "process",  # the helper process that played it (0: the run's own)
)
PLANES_COLUMNS = (
    "point",  # grid point
    "setup", "trial", "object",  # the world (Setups 2, 3: the round and its objects)
    "target",  # the object the first view's target point lies on (ground truth; "" if none)
    "first_view_grasp",  # the first view already holds a grasp (such a view does not re-align)
    "plane_found",  # the plane scoring found a plane
    "surface",  # what most of the chosen plane's inliers lie on (`SURFACE_LABELS`; ground truth)
    "on_target",  # share of its inliers on the target (ground truth)
    "normal_error_deg",  # its normal against the target's nearest true face
    "view_tilt_deg",  # the re-aligned view's tilt from straight down
)
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
    ),
}
REASON_LABELS = np.array([Reason(r).label if r in Reason._value2member_map_ else ""
                          for r in range(max(Reason) + 1)], dtype=object)  # Reason -> label
SURFACE_LABELS = np.array([s.name.lower().replace("_", " ") if s != Surface.NONE else ""
                           for s in sorted(Surface)], dtype=object)  # index: Surface + 1


def sort_attempts(frame: pd.DataFrame) -> pd.DataFrame:
    """Rows in the canonical order: point, setup, trial (the round in Setups 2, 3), attempt
    (unattempted last), object."""
    order = frame.assign(attempt_order=frame["attempt"].where(frame["attempt"] >= 0, 99))
    order = order.sort_values(SORT, kind="stable").drop(columns="attempt_order")
    return order.reset_index(drop=True)


def outcome_label(frame: pd.DataFrame) -> pd.Series:
    """One short label per attempt row: its outcome when executed, else why no grasp was
    executed ("no grasp: NO_ROOM", "align: NO_PLANE", "no target", "not attempted: ...")."""
    label = frame["reason"].where(frame["outcome"] == "NOT_EXECUTED", frame["outcome"])
    return label.str.replace("detection: ", "no grasp: ").str.replace("alignment: ", "align: ")
