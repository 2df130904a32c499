"""The `graspjax` command's arguments: one subcommand each for `cli`'s commands (`graspjax
--help`); what they mean is checked in `arguments` and carried out in `cli`."""

from __future__ import annotations

import argparse

from graspjax.config import METHODS

CONFIG_HELP = ("settings file: the dotted keys of --set with their values, in TOML ([align] "
               "window_px = 12, or align.window_px = 12) or YAML (with PyYAML); a key may not "
               "be given by --set as well (keys: graspjax config)")


class Parser(argparse.ArgumentParser):
    """argparse's parser, its mistakes one line as graspjax's own are (argparse prints its usage
    first): "graspjax run: error: ... (graspjax run --help)", exit status 2. Its subcommands'
    parsers are of this class too (`add_subparsers`' default)."""

    def error(self, message: str):
        if message.endswith("expected one argument"):  # a value that starts with "-"
            option = message.removeprefix("argument ").split(":")[0].split("/")[0]
            message += f" (a value that starts with '-' goes after '=': {option}=VALUE)"
        self.exit(2, f"{self.prog}: error: {message} ({self.prog} --help)\n")


def add_experiment_arguments(p) -> None:
    p.add_argument("--table", help="paper preset: 1 (a-f, Setups 1-3), 2 (g-l, Setup 1) or 1,2")
    p.add_argument("--setup", help="setup 1, 2 or 3 (or a list, e.g. 1,2,3)")
    p.add_argument("--objects", help="objects to attempt, e.g. a,b,c (default a-f)")
    p.add_argument("--trials", type=int, default=10,
                   help="trials per object (Setup 1) or rounds (Setups 2, 3); paper: 10")
    p.add_argument("--seed", type=int, default=0,
                   help="base seed of every layout and key (0 to 2147483647)")
    p.add_argument("--preset", choices=["paper", "realistic"], default="paper",
                   help="paper: exact depth, the paper's checks, exact execution (default); "
                        "realistic: Kinect sensor, our wall check, execution error")
    p.add_argument("--method", choices=list(METHODS),
                   help="grasp method: paper (the double T-beam, default), highest-pca or "
                        "antipodal (docs/baselines.md); the same as --set method=...")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a configuration value, e.g. align.window_px=10")
    p.add_argument("--config", metavar="FILE", help=CONFIG_HELP)
    p.add_argument("--batch", type=int,
                   help="worlds per device call, at most 65536 (default: 2048 on a GPU, 10 on a "
                        "CPU): a world's rows depend on its key, the device kind and this alone")
    p.add_argument("--resume", action="store_true",
                   help="continue the run in --out (same command): only unfinished chunks run")
    p.add_argument("--overwrite", action="store_true", help="replace a run already in --out")
    p.add_argument("--part", metavar="I/N",
                   help="run every N-th chunk from chunk I, into a folder shared by N processes "
                        "(one per host; see docs/running.md)")
    p.add_argument("--distributed", nargs="?", const="auto", metavar="HOST:PORT,N,I",
                   help="one of N processes (hosts) of one run on JAX's distributed runtime: "
                        "alone, the launcher says which (Slurm, Open MPI); else coordinator, "
                        "process count, this process's index (see docs/running.md)")
    p.add_argument("--processes", type=int, metavar="N",
                   help="CPU: play the run's groups (programs) in up to N processes side by side "
                        "(default: GRASPJAX_PROCESSES, else one per core, at most 4; a GPU takes "
                        "1); the same attempts as one process")
    p.add_argument("--fast", action="store_true",
                   help="GPU: allow non-deterministic XLA ops (the bin scene steps about 1.1x as fast; "
                        "not bit-reproducible)")
    p.add_argument("--save-views", choices=["none", "failed", "all"], default="none",
                   help="keep the images, detections and planes of these attempts (views/*.npz)")
    p.add_argument("--max-views", type=int, default=100,
                   help="keep views of at most this many attempts (default 100)")
    p.add_argument("--dry-run", action="store_true",
                   help="print the worlds, chunks and programs the run would play, which "
                        "programs are stored, and an estimated time from the timings last "
                        "recorded on this device kind; run nothing, write nothing")
    p.add_argument("--compile-first", action="store_true",
                   help="load or compile every program on every device before the first chunk "
                        "(benchmarks: timings.csv then times play alone; the same rows)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def add_detect_parser(sub):
    """`graspjax detect`'s arguments (its sub-parser, returned)."""
    p = sub.add_parser("detect", help="detect grasps on depth images (real cameras welcome)")
    p.add_argument("images", nargs="+", metavar="IMAGE",
                   help="depth images of one size: .npy (H, W) or (H, W, 1) in metres, .npz with "
                        "'depth' (m) and optionally 'K', or with an organised point cloud 'xyz' "
                        "(H, W, 3; m, camera frame; intrinsics fitted to it), a 16-bit .png or "
                        ".tif (see --depth-scale), a float32 .tif in metres, an organised .pcd "
                        "or .ply cloud (read as 'xyz'); a directory stands for its .npy, .npz, "
                        ".png, .tif, .tiff, .pcd and .ply files")
    p.add_argument("--depth-scale", type=float, default=0.001,
                   help="metres per unit of a 16-bit .png or .tif (default 0.001: millimetres)")
    p.add_argument("--camera-pose", metavar="FILE",
                   help="the camera's pose, camera to world (a 4x4 .npy/.txt/JSON, or a gqcnn "
                        ".tf): every grasp is also given in the world frame (pose_world)")
    g = p.add_argument_group("intrinsics (full-resolution pixels; one way at most; default: "
                             "each .npz's K, else the Kinect's 57 x 43 degrees, with a one-line "
                             "warning on stderr)")
    g.add_argument("--intrinsics", metavar="FILE",
                   help="JSON with fx, fy, cx, cy (or K), Open3D's PinholeCameraIntrinsic JSON, "
                        "a ROS camera_info .yaml, a gqcnn .intr, or a 3x3 .npy/.txt")
    g.add_argument("--K", metavar="FX,0,CX,0,FY,CY,0,0,1", help="the 3x3 matrix, row by row")
    g.add_argument("--fx", type=float, help="focal length in pixels")
    g.add_argument("--fy", type=float, help="focal length in pixels (default: --fx)")
    g.add_argument("--cx", type=float, help="principal point column (default: image centre)")
    g.add_argument("--cy", type=float, help="principal point row (default: image centre)")
    g.add_argument("--fov-x", type=float, help="horizontal field of view in degrees")
    g.add_argument("--fov-y", type=float, help="vertical field of view in degrees")
    g = p.add_argument_group("workspace (everything outside is invalid for every step)")
    g.add_argument("--roi", metavar="X0,Y0,X1,Y1",
                   help="columns X0 <= u < X1 and rows Y0 <= v < Y1, full-resolution pixels")
    g.add_argument("--mask", metavar="FILE", help="PNG or .npy of the image's size, nonzero = workspace")
    g.add_argument("--range", metavar="MIN,MAX", help="depth range in metres (default 0,10)")
    g.add_argument("--bin", action="store_true",
                   help="a bin or tote: each image's workspace is its bin's interior found from "
                        "depth (the floor's convex hull) within --roi/--mask; give a --roi around "
                        "the whole bin, or none")
    p.add_argument("--downsample", type=int,
                   help="block factor of the detection resolution (default: the one that brings "
                        "a pixel nearest 1.4 mm at the image's median depth, from the intrinsics)")
    p.add_argument("--preset", choices=["paper", "realistic"], default="paper",
                   help="the detector's checks: the paper's, or with the wall check where the "
                        "jaws touch (realistic)")
    p.add_argument("--method", choices=list(METHODS),
                   help="grasp method on each target's window: paper (the double T-beam, "
                        "default), highest-pca or antipodal (docs/baselines.md); the same jaw "
                        "checks and ranking follow")
    p.add_argument("--top", type=int, metavar="K",
                   help="return the K best distinct grasps, ranked (default 1)")
    p.add_argument("--out", help="results table: FILE.csv, or a directory for results.csv and "
                                 "results.json")
    p.add_argument("--json", help="write the record (a list for several images) to this JSON file")
    p.add_argument("--figure", help="write the debug figure of the one image to this PNG file")
    p.add_argument("--figures", metavar="DIR", help="write one debug figure per image into DIR")
    p.add_argument("--batch", type=int, help="images per compiled call (default 16 on a GPU, 1 "
                                             "on a CPU: one image at a time runs faster there)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a configuration value, e.g. align.window_px=10 or "
                        "image.max_targets=1")
    return p


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(
        prog="graspjax",
        description="Batch evaluator of double T-beam grasp detection and plane-detection "
                    "end-tool alignment (JAX / MuJoCo MJX).")
    sub = parser.add_subparsers(dest="command", required=True)

    add_detect_parser(sub)

    p = sub.add_parser("run", help="grasp attempts in simulation: attempts, tables, figures")
    add_experiment_arguments(p)

    p = sub.add_parser("sweep", help="a parameter grid of runs (e.g. --grid align.window_px=5,15)")
    add_experiment_arguments(p)
    p.add_argument("--grid", action="append", metavar="KEY=V1,V2,...",
                   help="values of one configuration key; several --grid give the full grid")
    p.add_argument("--paired", action="store_true",
                   help="every grid point plays the same worlds (same seed): paired differences")
    p.add_argument("--reuse", metavar="RUN",
                   help="a finished run of the same worlds (same command without the grid): with a "
                        "--paired grid of align.* or procedure.max_reorientations, play again only "
                        "its worlds where a view held no grasp, copy the others' rows")

    p = sub.add_parser("planes", help="perception-only study of the re-alignment's plane: every "
                       "first view of settled worlds, judged per grid point (no grasping)")
    p.add_argument("--setup", required=True, help="setup 1, 2 or 3 (or a list, e.g. 1,2,3)")
    p.add_argument("--objects", help="objects of the worlds, e.g. a,b,c (default a-f)")
    p.add_argument("--trials", type=int, default=100,
                   help="worlds per object (Setup 1) or rounds (Setups 2, 3); a run's first "
                        "attempts with the same seed")
    p.add_argument("--seed", type=int, default=0,
                   help="base seed of every layout and key (0 to 2147483647)")
    p.add_argument("--preset", choices=["paper", "realistic"], default="paper")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a configuration value, e.g. procedure.view_tilt_deg=30")
    p.add_argument("--config", metavar="FILE", help=CONFIG_HELP)
    p.add_argument("--grid", action="append", metavar="KEY=V1,V2,...",
                   help="traced alignment values, e.g. align.window_px=5,15,30 (every "
                        "combination; one compiled program)")
    p.add_argument("--batch", type=int,
                   help="worlds per device call, at most 65536 (default: 2048 on a GPU, 10 on a CPU)")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--overwrite", action="store_true", help="replace a study already in --out")
    p.add_argument("--dry-run", action="store_true",
                   help="print the worlds and chunks the study would play; write nothing")
    p.add_argument("--quiet", action="store_true", help="no progress bar")

    p = sub.add_parser("config", help="list the configuration keys --set takes: default per "
                       "preset, unit, traced (a sweep compiles once) or static, meaning")
    p.add_argument("prefix", nargs="?", default="", metavar="PREFIX",
                   help="only the keys that start with this, e.g. align.")
    p.add_argument("--preset", choices=["paper", "realistic"],
                   help="only this preset's defaults (default: every preset's)")
    p.add_argument("--format", choices=["text", "csv", "json"], default="text",
                   help="aligned text (default), CSV or JSON")

    p = sub.add_parser("report", help="rebuild tables and figures from DIR/attempts.csv, or "
                                      "compare runs paired (--compare)")
    p.add_argument("folder", nargs="?", help="a run or sweep output directory")
    p.add_argument("--compare", nargs="+", metavar="DIR",
                   help="print a paired comparison instead: runs of the same worlds against the "
                        "first (--compare A B ...), or a paired sweep's grid points against its "
                        "first (--compare SWEEP); per table column success, first view + rescued, "
                        "objects gained / lost, McNemar's z and p")
    p.add_argument("--debug", type=int, default=0, metavar="N",
                   help="also draw the first N saved attempts (views/) into DIR/debug/")

    p = sub.add_parser("assets", help="write the objects' meshes and MJCF files (assets/objects)")
    p.add_argument("folder", nargs="?", default="assets/objects", help="output folder")

    p = sub.add_parser("bench", help="benchmarks (print numbers; compile time apart)")
    p.add_argument("what", choices=["perception", "detect", "physics", "pipeline", "finish"],
                   help="what to measure (detect: graspjax detect on real-looking images; "
                        "finish: a run's end after its last chunk, on --rows-from's rows)")
    p.add_argument("--rows-from", metavar="FOLDER",
                   help="finish: a finished run or sweep folder whose rows are repeated")
    p.add_argument("--rows", type=int, default=96_000,
                   help="finish: attempt rows of the run timed (default 96,000)")
    p.add_argument("--objects", default="abcdef", help="physics, pipeline: objects of the scene")
    p.add_argument("--setup", default="3", help="physics: setup 1, 2 or 3; pipeline: e.g. 1,2,3")
    p.add_argument("--seconds", type=float, default=1.0, help="physics: simulated time timed")
    p.add_argument("--trials", type=int, default=100, help="pipeline: trials (or rounds)")
    p.add_argument("--batch", type=int,
                   help="perception: images per call (default 4096); detect: images per call "
                        "(default 1024 on a GPU, 32 on the CPU); physics: worlds (default 4096 "
                        "on a GPU, 16 on the CPU); pipeline: worlds per batch (default: device-sized)")
    p.add_argument("--width", type=int, help="image width (perception 160, detect 640)")
    p.add_argument("--height", type=int, help="image height (perception 120, detect 480)")
    p.add_argument("--repeats", type=int, default=10, help="timed calls (median is reported)")
    p.add_argument("--out", help="write the full record to this JSON file")
    p.add_argument("--profile", metavar="DIR",
                   help="pipeline: play the first round under JAX's profiler; detect: one "
                        "more call under it (one image on a CPU, a batch elsewhere); write "
                        "DIR/trace/ and DIR/kernels.csv (device time per compiled operation and "
                        "its source line) and print where the time went")
    p.add_argument("--fast", action="store_true", help="GPU: allow non-deterministic XLA ops")
    p.add_argument("--preset", choices=["paper", "realistic"],
                   help="configuration preset (default paper; see graspjax run --help; "
                        "detect: as graspjax detect --preset)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE")
    return parser
