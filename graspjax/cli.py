"""The `graspjax` command line.

User mistakes (missing files, bad values, unknown keys) print one line to
stderr and exit with status 2; nothing is written unless everything worked.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

from graspjax.config import ConfigError
from graspjax.io import InputError


class UsageError(Exception):
    """A bad combination of command-line arguments (one line)."""


def _jsonable(value):
    """Convert arrays and numpy scalars to JSON values (nan -> null)."""
    import numpy as np

    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    array = np.asarray(value)
    if array.ndim > 0:
        return [_jsonable(v) for v in array.tolist()]
    item = array.item()
    if isinstance(item, float) and not math.isfinite(item):
        return None
    return item


def _check_writable(path: str | None) -> None:
    """Fail early, before any work, if an output file cannot be written."""
    if path is None:
        return
    parent = Path(path).resolve().parent
    if not parent.is_dir():
        raise InputError(f"cannot write {path}: directory {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise InputError(f"cannot write {path}: directory {parent} is not writable")


def _camera_from_args(args, width: int, height: int):
    from graspjax.camera import KINECT_FOV_X_DEG, KINECT_FOV_Y_DEG, Camera

    explicit = [args.fx, args.fy, args.cx, args.cy]
    if any(v is not None for v in explicit):
        if args.fov_x is not None or args.fov_y is not None:
            raise UsageError("give either --fov-x/--fov-y or --fx/--fy/--cx/--cy, not both")
        if args.fx is None:
            raise UsageError("--fy, --cx and --cy need --fx")
        if args.fx <= 0 or (args.fy is not None and args.fy <= 0):
            raise UsageError("focal lengths must be > 0")
        return Camera(width, height, float(args.fx), float(args.fy or args.fx),
                      (width - 1) / 2 if args.cx is None else float(args.cx),
                      (height - 1) / 2 if args.cy is None else float(args.cy))
    fov_x = KINECT_FOV_X_DEG if args.fov_x is None else args.fov_x
    fov_y = args.fov_y if args.fov_y is not None else (
        KINECT_FOV_Y_DEG if args.fov_x is None else None)
    try:
        return Camera.from_fov(width, height, fov_x, fov_y)
    except ValueError as exc:
        raise UsageError(str(exc)) from None


def _grasp_record(grasp) -> dict:
    from graspjax.perception import GraspReason

    return {
        "found": bool(grasp.found),
        "reason": GraspReason(int(grasp.reason)).name,
        "position": grasp.position,
        "closing_axis": grasp.closing_axis,
        "approach": grasp.approach,
        "width": grasp.width,
        "depth": grasp.depth,
        "surface_depth": grasp.surface_depth,
        "pixel": grasp.pixel,
        "nearest_pixel": grasp.nearest,
        "surface_pixels": grasp.surface_pixels,
        "valid_candidates": int(grasp.candidates.valid.sum()),
    }


def _alignment_record(alignment) -> dict:
    from graspjax.perception import AlignReason

    return {
        "found": bool(alignment.found),
        "reason": AlignReason(int(alignment.reason)).name,
        "normal": alignment.normal,
        "point": alignment.point,
        "inliers": alignment.inliers,
        "best": alignment.best,
        "counts": alignment.counts,
    }


def cmd_detect(args) -> int:
    """Run grasp detection and alignment on one depth image from disk."""
    _check_writable(args.json)
    _check_writable(args.figure)
    from graspjax.config import Config, override
    from graspjax.io import downsample, load_depth

    config = override(Config(), args.set or [])
    depth = load_depth(args.depth)
    full_h, full_w = depth.shape
    camera = _camera_from_args(args, full_w, full_h)
    factor = args.downsample if args.downsample is not None else max(1, full_w // 160)
    if factor < 1 or factor > min(full_w, full_h) // 8:
        raise UsageError(f"--downsample {factor} leaves less than 8x8 pixels")
    depth = downsample(depth, factor)
    if factor > 1:
        camera = camera.scaled(depth.shape[1], depth.shape[0])
    if not (depth > 0).any():
        raise InputError(f"{args.depth}: no valid depth pixels after downsampling")

    import jax

    from graspjax.perception import align_tool, detect_grasp

    grasp = jax.jit(detect_grasp)(depth, camera, config.detect, config.gripper)
    alignment = jax.jit(align_tool)(depth, camera, config.align)
    record = _jsonable({
        "image": str(args.depth),
        "working_resolution": [camera.width, camera.height],
        "downsample": factor,
        "camera": {"fx": camera.fx, "fy": camera.fy, "cx": camera.cx, "cy": camera.cy},
        "grasp": _grasp_record(grasp),
        "alignment": _alignment_record(alignment),
    })
    text = json.dumps(record, indent=2)
    figure = None
    if args.figure:
        from graspjax.viz import debug_figure

        figure = debug_figure(depth, camera, grasp, alignment, config, title=str(args.depth))
    from graspjax.io import write_atomic

    if args.json:
        write_atomic(args.json, (text + "\n").encode())
    if figure is not None:
        write_atomic(args.figure, figure)
    print(text)
    return 0


def cmd_bench(args) -> int:
    _check_writable(args.out)
    from graspjax.bench import format_perception, perception_benchmark
    from graspjax.config import Config, override

    if args.batch is not None and args.batch < 1 or args.repeats < 1:
        raise UsageError("--batch and --repeats must be >= 1")
    config = override(Config(), args.set or [])
    progress = lambda m: print(m, file=sys.stderr)  # noqa: E731
    if args.what == "perception":
        result = perception_benchmark(batch=args.batch or 4096, width=args.width, height=args.height,
                                      repeats=args.repeats, config=config, progress=progress)
        text = format_perception(result)
    elif args.what == "pipeline":
        from graspjax.bench import format_pipeline, pipeline_benchmark
        from graspjax.sim.objects import parse_letters

        try:
            letters = "".join(parse_letters(args.objects))
        except ValueError as exc:
            raise UsageError(str(exc)) from None
        setups = _ints(str(args.setup), "--setup", (1, 2, 3))
        result = pipeline_benchmark(letters, setups, args.trials, args.batch, config, progress)
        text = format_pipeline(result)
    else:
        from graspjax.bench import format_physics, physics_benchmark
        from graspjax.sim.objects import parse_letters

        try:
            letters = "".join(parse_letters(args.objects))
        except ValueError as exc:
            raise UsageError(str(exc)) from None
        setup = _ints(str(args.setup), "--setup", (1, 2, 3))[0]
        import jax

        batch = args.batch or (4096 if jax.default_backend() == "gpu" else 16)
        result = physics_benchmark(letters, setup, batch, args.seconds, config, progress)
        text = format_physics(result)
    if args.out:
        from graspjax.io import write_atomic

        write_atomic(args.out, (json.dumps(_jsonable(result), indent=2) + "\n").encode())
    print(text)
    return 0


def _ints(text: str, name: str, allowed) -> tuple[int, ...]:
    try:
        values = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise UsageError(f"{name} takes comma-separated integers, got {text!r}") from None
    bad = [v for v in values if v not in allowed]
    if bad or not values:
        raise UsageError(f"{name} must be among {', '.join(map(str, allowed))}, got {text!r}")
    return values


def _jobs(args):
    """Jobs from --table or --setup/--objects, validated (no compilation yet)."""
    from graspjax.runner import Job, table_job
    from graspjax.sim.objects import parse_letters

    if args.trials < 1:
        raise UsageError(f"--trials must be >= 1, got {args.trials}")
    if args.seed < 0:
        raise UsageError(f"--seed must be >= 0, got {args.seed}")
    if args.batch is not None and args.batch < 1:
        raise UsageError(f"--batch must be >= 1, got {args.batch}")
    if args.max_views < 0:
        raise UsageError(f"--max-views must be >= 0, got {args.max_views}")
    if args.resume and args.overwrite:
        raise UsageError("give --resume or --overwrite, not both")
    _part(args.part)
    if (args.table is None) == (args.setup is None):
        raise UsageError("give either --table 1|2|1,2 or --setup S [--objects ...]")
    if args.table is not None:
        if args.objects is not None:
            raise UsageError("--objects goes with --setup; the tables fix their objects")
        return [table_job(t, args.trials) for t in _ints(args.table, "--table", (1, 2))]
    try:
        objects = parse_letters(args.objects or "abcdef")
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    return [Job(objects, _ints(args.setup, "--setup", (1, 2, 3)), args.trials)]


def _grid(items: list[str], base):
    """--grid key=v1,v2,... -> (keys, list of (values dict, config)); every point validated.

    Keys joined by ':' vary together: --grid camera.width:camera.height=80:60,160:120.
    """
    import itertools

    from graspjax.config import override, parse_assignments

    axes = []
    for name, text in parse_assignments(items).items():
        names = name.split(":")
        values = [v.strip().split(":") for v in text.split(",") if v.strip()]
        if not values:
            raise UsageError(f"--grid {name}= has no values")
        if any(len(v) != len(names) for v in values):
            raise UsageError(f"--grid {name}: every value needs {len(names)} parts joined by ':'")
        axes.append([dict(zip(names, v, strict=True)) for v in values])
    keys = [k for axis in axes for k in axis[0]]
    points = []
    for combo in itertools.product(*axes):
        assignment = {k: v for part in combo for k, v in part.items()}
        points.append((assignment, override(base, assignment)))
    return keys, points


def _progress(total: int, quiet: bool, initial: int = 0):
    from tqdm import tqdm

    bar = tqdm(total=total, initial=initial, unit="attempt", disable=quiet, dynamic_ncols=True,
               file=sys.stderr, smoothing=0.05)

    def log(message):
        if not quiet:
            bar.write(message, file=sys.stderr)

    return bar, log


def _experiment(args, grid_items=None) -> int:
    import dataclasses

    from graspjax import runner
    from graspjax.config import Config, differences, flatten, override
    from graspjax.outputs import RunFolder, check_output_folder, environment, finish_frame, run_id
    from graspjax.views import ViewSaver

    jobs = _jobs(args)
    part, parts = _part(args.part)
    out = check_output_folder(args.out, args.resume or parts > 1, args.overwrite)
    config = override(Config(), args.set or [])
    keys, points = ([], [({}, config)]) if grid_items is None else _grid(grid_items, config)
    configs = [c for _, c in points]
    batch = args.batch or runner.default_batch()
    groups = runner.plan(jobs, configs, args.seed)
    chunks = runner.chunks(groups, batch)
    meta = {"seed": args.seed, "jobs": [dataclasses.asdict(j) for j in jobs],
            "overrides": differences(config, Config()),
            "grid": {k: [p[0][k] for p in points] for k in keys}, "points": len(points),
            "config": flatten(config),
            "batch": batch, "deterministic": not args.fast,
            "xla_flags": os.environ.get("XLA_FLAGS", ""), "save_views": args.save_views,
            **environment()}
    meta = {"run_id": run_id(meta), **meta}
    folder = RunFolder(out, meta, len(chunks), args.resume, shared=parts > 1)
    skip = folder.done | {c.index for c in chunks if c.index % parts != part}
    per_chunk = {c.index: sum(len(w.objects) for w in c.worlds) for c in chunks
                 if c.index % parts == part}
    bar, log = _progress(sum(per_chunk.values()), args.quiet,
                         sum(n for c, n in per_chunk.items() if c in folder.done))
    if grid_items is not None:
        log(f"{len(points)} grid points of {', '.join(keys)}; point i has seed {args.seed} + i")
    saver = ViewSaver(out, args.save_views, args.max_views, configs)
    with bar:
        for chunk, frame, timings, views in runner.run(
                groups, configs, batch, skip, keep_views=args.save_views != "none",
                progress=bar.update, log=log):
            frame = finish_frame(frame, configs, keys, meta["run_id"], config)
            folder.add(chunk.index, frame, timings)
            if views is not None:
                saver.save(chunk, frame, views)
    files = folder.finish()
    if not files:
        print(f"part {part}/{parts} done; {len(folder.done)} of {len(chunks)} chunks of the run are "
              f"done in {out} (the part that completes the last chunk writes the results)")
        return 0
    import pandas as pd

    success = pd.read_csv(out / "attempts.csv", usecols=["success"])["success"]
    print(f"{len(success)} attempts, success {success.mean():.1%}; wrote "
          + ", ".join(p.name for p in files) + f" to {out}")
    for name in ("table1.md", "table2.md"):
        if (out / name).exists() and grid_items is None:
            print((out / name).read_text())
    return 0


def _part(text: str | None) -> tuple[int, int]:
    """--part I/N -> (I, N); no --part is (0, 1)."""
    if text is None:
        return 0, 1
    try:
        part, parts = (int(v) for v in text.split("/"))
    except ValueError:
        raise UsageError(f"--part takes I/N (e.g. 0/4), got {text!r}") from None
    if not 0 <= part < parts:
        raise UsageError(f"--part I/N needs 0 <= I < N, got {text!r}")
    return part, parts


def cmd_run(args) -> int:
    """Run grasp attempts and write attempts, tables and figures."""
    return _experiment(args)


def cmd_sweep(args) -> int:
    """Run a full parameter grid; every point has its own seed (seed + point index)."""
    if not args.grid:
        raise UsageError("sweep needs at least one --grid key=v1,v2,...")
    return _experiment(args, args.grid)


def cmd_report(args) -> int:
    from graspjax.report import write_report

    folder = Path(args.folder)
    if not folder.is_dir():
        raise InputError(f"no such directory: {folder}")
    if args.debug < 0:
        raise UsageError(f"--debug must be >= 0, got {args.debug}")
    try:
        files = write_report(folder, debug=args.debug)
    except (FileNotFoundError, ValueError) as exc:
        raise InputError(str(exc).splitlines()[0]) from None
    print("wrote " + ", ".join(str(p.relative_to(folder)) for p in files) + f" to {folder}")
    return 0


def _add_experiment_arguments(p) -> None:
    p.add_argument("--table", help="paper preset: 1 (a-f, Setups 1-3), 2 (g-l, Setup 1) or 1,2")
    p.add_argument("--setup", help="setup 1, 2 or 3 (or a list, e.g. 1,2,3)")
    p.add_argument("--objects", help="objects to attempt, e.g. a,b,c (default a-f)")
    p.add_argument("--trials", type=int, default=10,
                   help="trials per object (Setup 1) or rounds (Setups 2, 3); paper: 10")
    p.add_argument("--seed", type=int, default=0, help="base seed of every layout and key")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a configuration value, e.g. align.window_px=10")
    p.add_argument("--batch", type=int,
                   help="worlds per chunk (default: 4096 per GPU, 32 on the CPU); the same seed and "
                        "batch on the same device kind give the same attempts")
    p.add_argument("--resume", action="store_true",
                   help="continue the run in --out (same command): only unfinished chunks run")
    p.add_argument("--overwrite", action="store_true", help="replace a run already in --out")
    p.add_argument("--part", metavar="I/N",
                   help="run every N-th chunk from chunk I, into a folder shared by N processes "
                        "(one per host; see docs/running.md)")
    p.add_argument("--fast", action="store_true",
                   help="GPU: allow non-deterministic XLA ops (about 20%% faster, not bit-reproducible)")
    p.add_argument("--save-views", choices=["none", "failed", "all"], default="none",
                   help="keep the images, detections and planes of these attempts (views/*.npz)")
    p.add_argument("--max-views", type=int, default=100,
                   help="keep views of at most this many attempts (default 100)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="graspjax",
        description="Batch evaluator of double T-beam grasp detection and plane-detection "
                    "end-tool alignment (JAX / MuJoCo MJX).")
    sub = parser.add_subparsers(dest="command", required=True)

    p = sub.add_parser("detect", help="detect a grasp and an alignment plane on a depth image")
    p.add_argument("depth", help="depth image: .npy in metres or 16-bit .png in millimetres")
    p.add_argument("--fov-x", type=float, help="horizontal field of view in degrees (default 57)")
    p.add_argument("--fov-y", type=float, help="vertical field of view in degrees (default 43)")
    p.add_argument("--fx", type=float, help="focal length in pixels (full resolution)")
    p.add_argument("--fy", type=float, help="focal length in pixels (default: --fx)")
    p.add_argument("--cx", type=float, help="principal point column (default: image centre)")
    p.add_argument("--cy", type=float, help="principal point row (default: image centre)")
    p.add_argument("--downsample", type=int,
                   help="block factor to the working resolution (default: width // 160)")
    p.add_argument("--json", help="also write the result to this JSON file")
    p.add_argument("--figure", help="write the debug figure to this PNG file")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a configuration value, e.g. align.window_px=10")
    p.set_defaults(func=cmd_detect)

    p = sub.add_parser("run", help="grasp attempts in simulation: attempts, tables, figures")
    _add_experiment_arguments(p)
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("sweep", help="a parameter grid of runs (e.g. --grid align.window_px=5,15)")
    _add_experiment_arguments(p)
    p.add_argument("--grid", action="append", metavar="KEY=V1,V2,...",
                   help="values of one configuration key; several --grid give the full grid")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("report", help="rebuild tables and figures from DIR/attempts.csv")
    p.add_argument("folder", help="a run or sweep output directory")
    p.add_argument("--debug", type=int, default=0, metavar="N",
                   help="also draw the first N saved attempts (views/) into DIR/debug/")
    p.set_defaults(func=cmd_report)

    p = sub.add_parser("bench", help="benchmarks (print numbers; compile time apart)")
    p.add_argument("what", choices=["perception", "physics", "pipeline"], help="what to measure")
    p.add_argument("--objects", default="abcdef", help="physics, pipeline: objects of the scene")
    p.add_argument("--setup", default="3", help="physics: setup 1, 2 or 3; pipeline: e.g. 1,2,3")
    p.add_argument("--seconds", type=float, default=1.0, help="physics: simulated time timed")
    p.add_argument("--trials", type=int, default=100, help="pipeline: trials (or rounds)")
    p.add_argument("--batch", type=int,
                   help="perception: images per call (default 4096); physics: worlds (default 4096 "
                        "on a GPU, 16 on the CPU); pipeline: worlds per batch (default: device-sized)")
    p.add_argument("--width", type=int, default=160)
    p.add_argument("--height", type=int, default=120)
    p.add_argument("--repeats", type=int, default=10, help="timed calls (median is reported)")
    p.add_argument("--out", help="write the full record to this JSON file")
    p.add_argument("--fast", action="store_true", help="GPU: allow non-deterministic XLA ops")
    p.add_argument("--set", action="append", metavar="KEY=VALUE")
    p.set_defaults(func=cmd_bench)
    return parser


def _compilation_cache() -> None:
    """Keep compiled programs across runs (set GRASPJAX_CACHE=0 to switch off)."""
    import os

    folder = os.environ.get("GRASPJAX_CACHE", os.path.expanduser("~/.cache/graspjax/jax"))
    if folder in ("0", "off", ""):
        return
    import jax

    jax.config.update("jax_compilation_cache_dir", folder)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)


def _deterministic_gpu(args) -> None:
    """XLA's GPU scatter-adds are not deterministic: ask for deterministic ops unless --fast.

    XLA reads the flag when JAX starts its backend, so this runs before any device is used.
    """
    if getattr(args, "fast", True):
        return
    flag = "--xla_gpu_deterministic_ops=true"
    flags = os.environ.get("XLA_FLAGS", "")
    if flag not in flags:
        os.environ["XLA_FLAGS"] = f"{flags} {flag}".strip()


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    _deterministic_gpu(args)
    _compilation_cache()
    try:
        return args.func(args)
    except (InputError, ConfigError, UsageError) as exc:
        print(f"graspjax: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("graspjax: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
