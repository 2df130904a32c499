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


def _detect_line(rec: dict) -> str:
    """One line of the table `graspjax detect` prints for several images."""
    text = f"{rec['image']}: {rec['reason']}"
    if rec["found"]:
        x, y, z = rec["grasp"]["position"]
        text += (f", width {100 * rec['grasp']['width']:.1f} cm at ({x:+.3f}, {y:+.3f}, {z:.3f}) m"
                 f", pixel ({rec['grasp']['pixel'][0]:.0f}, {rec['grasp']['pixel'][1]:.0f})")
    support = rec["support_plane"]
    if support["found"]:
        text += f"; {rec['view']} view, support tilt {support['tilt_deg']:.1f} deg"
    return text


def cmd_detect(args) -> int:
    """Detect grasps on depth images from disk: one JSON record each, or a table of many."""
    from graspjax import realdepth
    from graspjax.io import write_atomic

    images = realdepth.expand_images(args.images)
    many = len(images) > 1
    if args.figure and many:
        raise UsageError("--figure takes one image; give --figures DIR for several")
    if args.batch is not None and args.batch < 1:
        raise UsageError(f"--batch must be >= 1, got {args.batch}")
    out_csv = args.out if args.out and args.out.lower().endswith(".csv") else None
    out_dir = args.out if args.out and out_csv is None else None
    _check_writable(args.json)
    _check_writable(args.figure)
    realdepth.check_output(out_csv, "--out")
    realdepth.check_output(out_dir, "--out", directory=True)
    realdepth.check_output(args.figures, "--figures", directory=True)
    intrinsics = {"fx": args.fx, "fy": args.fy, "cx": args.cx, "cy": args.cy, "k": args.K,
                  "intrinsics": args.intrinsics, "fov_x": args.fov_x, "fov_y": args.fov_y}
    inputs = realdepth.prepare(images, depth_scale=args.depth_scale, intrinsics=intrinsics,
                               roi=args.roi, mask=args.mask, depth_range=args.range,
                               downsample=args.downsample, overrides=args.set or [])

    names = realdepth.figure_names(inputs.paths)
    figures: dict[int, bytes] = {}
    if args.figures:
        Path(args.figures).mkdir(exist_ok=True)

    def each(i, depth, camera, result):
        png = realdepth.figure(inputs, depth, camera, result, title=str(inputs.paths[i]))
        if args.figures:
            write_atomic(Path(args.figures) / names[i], png)
        else:
            figures[i] = png

    from tqdm import tqdm

    with tqdm(total=len(inputs.paths), unit="image", disable=args.quiet or not many,
              dynamic_ncols=True, file=sys.stderr) as bar:
        log = (lambda m: None) if args.quiet else (lambda m: bar.write(m, file=sys.stderr))
        records = realdepth.run(inputs, args.batch or 16, bar.update, log,
                                each if (args.figure or args.figures) else None)
    records = _jsonable(records)
    if args.json:
        write_atomic(args.json, (json.dumps(records if many else records[0], indent=2) + "\n").encode())
    if args.figure:
        write_atomic(args.figure, figures[0])
    if out_csv:
        write_atomic(out_csv, realdepth.csv_bytes(records))
    if out_dir:
        Path(out_dir).mkdir(exist_ok=True)
        write_atomic(Path(out_dir) / "results.csv", realdepth.csv_bytes(records))
        write_atomic(Path(out_dir) / "results.json", (json.dumps(records, indent=2) + "\n").encode())
    if many:
        for rec in records:
            print(_detect_line(rec))
        print(f"{sum(r['found'] for r in records)} of {len(records)} images with a grasp")
    else:
        print(json.dumps(records[0], indent=2))
    return 0


def _bench_detect(args, progress):
    """`graspjax bench detect`: the real-image pipeline, single-image latency and images/s."""
    import jax

    from graspjax.bench import detect_benchmark, format_detect
    from graspjax.realdepth import split_overrides

    config, scene = split_overrides(args.set or [])
    batch = args.batch or (1024 if jax.default_backend() == "gpu" else 32)
    result = detect_benchmark(batch=batch, width=args.width or 640, height=args.height or 480,
                              repeats=args.repeats, config=config, scene=scene, progress=progress)
    return result, format_detect(result)


def cmd_bench(args) -> int:
    _check_writable(args.out)
    from graspjax.bench import format_perception, perception_benchmark
    from graspjax.config import override, preset

    if args.batch is not None and args.batch < 1 or args.repeats < 1:
        raise UsageError("--batch and --repeats must be >= 1")
    if args.what == "detect" and args.preset is not None:
        raise UsageError("bench detect runs the real-image pipeline, which has no preset: give "
                         "its settings with --set (e.g. --set detect.wall_check=true)")
    progress = lambda m: print(m, file=sys.stderr)  # noqa: E731
    config = (None if args.what == "detect"
              else override(preset(args.preset or "paper"), args.set or []))
    if args.what == "detect":
        result, text = _bench_detect(args, progress)
    elif args.what == "perception":
        result = perception_benchmark(batch=args.batch or 4096, width=args.width or 160,
                                      height=args.height or 120, repeats=args.repeats,
                                      config=config, progress=progress)
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
    if getattr(args, "max_views", 0) < 0:
        raise UsageError(f"--max-views must be >= 0, got {args.max_views}")
    if getattr(args, "resume", False) and args.overwrite:
        raise UsageError("give --resume or --overwrite, not both")
    _part(getattr(args, "part", None))
    args.table = getattr(args, "table", None)
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


def _progress(total: int, quiet: bool, initial: int = 0, unit: str = "attempt"):
    from tqdm import tqdm

    bar = tqdm(total=total, initial=initial, unit=unit, disable=quiet, dynamic_ncols=True,
               file=sys.stderr, smoothing=0.05)

    def log(message):
        if not quiet:
            bar.write(message, file=sys.stderr)

    return bar, log


def _experiment(args, grid_items=None) -> int:
    import dataclasses

    from graspjax import runner
    from graspjax.config import Config, differences, flatten, override, preset
    from graspjax.outputs import RunFolder, check_output_folder, environment, finish_frame, run_id
    from graspjax.views import ViewSaver

    jobs = _jobs(args)
    part, parts = _part(args.part)
    out = check_output_folder(args.out, args.resume or parts > 1, args.overwrite)
    config = override(preset(args.preset), args.set or [])
    keys, points = ([], [({}, config)]) if grid_items is None else _grid(grid_items, config)
    configs = [c for _, c in points]
    batch = args.batch or runner.default_batch()
    paired = getattr(args, "paired", False)
    groups = runner.plan(jobs, configs, args.seed, paired)
    chunks = runner.chunks(groups, batch)
    meta = {"seed": args.seed, "paired": paired, "preset": args.preset,
            "jobs": [dataclasses.asdict(j) for j in jobs],
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
        log(f"{len(points)} grid points of {', '.join(keys)}; "
            + (f"every point has seed {args.seed} (paired)" if paired
               else f"point i has seed {args.seed} + i"))
    saver = ViewSaver(out, args.save_views, args.max_views, configs)
    with bar:
        for chunk, frame, layouts, timings, views in runner.run(
                groups, configs, batch, skip, keep_views=args.save_views != "none",
                progress=bar.update, log=log):
            frame = finish_frame(frame, configs, keys, meta["run_id"], config)
            folder.add(chunk.index, frame, layouts, timings)
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
    """Run a full parameter grid; every point has its own seed (seed + point index), or with
    --paired the same seed (the same worlds)."""
    if not args.grid:
        raise UsageError("sweep needs at least one --grid key=v1,v2,...")
    return _experiment(args, args.grid)


def cmd_planes(args) -> int:
    """Perception-only plane study: settle worlds, take each first view, judge the
    re-alignment's plane for every grid point of traced alignment values."""
    import dataclasses
    import json

    import jax

    from graspjax import planes, runner
    from graspjax.config import Config, differences, flatten, override, preset
    from graspjax.outputs import check_output_folder, environment

    jobs = _jobs(args)
    out = check_output_folder(args.out, overwrite=args.overwrite)
    config = override(preset(args.preset), args.set or [])
    keys, points = _grid(args.grid or [], config) if args.grid else ([], [({}, config)])
    bad = [k for k in keys if not k.startswith("align.")]
    if bad or any(jax.tree.structure(c) != jax.tree.structure(config) for _, c in points):
        raise UsageError("planes --grid takes traced align.* values that compile once (e.g. "
                         f"align.window_px, align.distance_threshold), got {', '.join(keys)}")
    groups = runner.plan(jobs, [config], args.seed)
    batch = args.batch or runner.default_batch()
    total = sum(len(g.worlds) for g in groups)
    bar, _ = _progress(total, args.quiet, unit="world")
    with bar:
        rows, timings = planes.study(groups, [c for _, c in points], batch, bar.update)
    grid = {k: [p[0][k] for p in points] for k in keys}
    for k, values in grid.items():
        rows.insert(1 + list(grid).index(k), k, [values[i] for i in rows.point])
    summary = planes.summarize(rows, grid)
    out.mkdir(parents=True, exist_ok=True)
    rows.to_csv(out / "planes.csv.gz", index=False)
    summary.to_csv(out / "planes_summary.csv", index=False)
    meta = {"seed": args.seed, "preset": args.preset, "jobs": [dataclasses.asdict(j) for j in jobs],
            "overrides": differences(config, Config()), "grid": grid, "batch": batch,
            "config": flatten(config), "timings": timings, **environment()}
    (out / "config.json").write_text(json.dumps(meta, indent=1, default=_jsonable))
    print(summary.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    print(f"{timings['views_scored']:,} views scored in {timings['score_s']:.2f} s "
          f"({timings['views_per_s']:,.0f} views/s; compile {timings['score_compile_s']:.1f} s, "
          f"settle {timings['settle_s']:.1f} s, first views {timings['view_s']:.1f} s); wrote "
          f"planes.csv.gz, planes_summary.csv, config.json to {out}")
    return 0


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
    p.add_argument("--preset", choices=["paper", "realistic"], default="paper",
                   help="paper: exact depth, the paper's checks, exact execution (default); "
                        "realistic: Kinect sensor, our wall check, execution error")
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

    p = sub.add_parser("detect", help="detect grasps on depth images (real cameras welcome)")
    p.add_argument("images", nargs="+", metavar="IMAGE",
                   help="depth images of one size: .npy (H, W) or (H, W, 1) in metres, .npz with "
                        "'depth' (m) and optionally 'K', or a 16-bit .png (see --depth-scale); "
                        "a directory stands for its .npy, .npz and .png files")
    p.add_argument("--depth-scale", type=float, default=0.001,
                   help="metres per unit of a 16-bit .png (default 0.001: millimetres)")
    g = p.add_argument_group("intrinsics (full-resolution pixels; one way at most; default: "
                             "each .npz's K, else the Kinect's 57 x 43 degrees)")
    g.add_argument("--intrinsics", metavar="FILE",
                   help="JSON with fx, fy, cx, cy (or K), a gqcnn .intr, or a 3x3 .npy/.txt")
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
    p.add_argument("--downsample", type=int,
                   help="block factor of the detection resolution (default: nearest to width / 640)")
    p.add_argument("--out", help="results table: FILE.csv, or a directory for results.csv and "
                                 "results.json")
    p.add_argument("--json", help="write the record (a list for several images) to this JSON file")
    p.add_argument("--figure", help="write the debug figure of the one image to this PNG file")
    p.add_argument("--figures", metavar="DIR", help="write one debug figure per image into DIR")
    p.add_argument("--batch", type=int, help="images per compiled call (default 16)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a configuration value, e.g. align.window_px=10 or "
                        "scene.max_targets=1")
    p.set_defaults(func=cmd_detect)

    p = sub.add_parser("run", help="grasp attempts in simulation: attempts, tables, figures")
    _add_experiment_arguments(p)
    p.set_defaults(func=cmd_run)

    p = sub.add_parser("sweep", help="a parameter grid of runs (e.g. --grid align.window_px=5,15)")
    _add_experiment_arguments(p)
    p.add_argument("--grid", action="append", metavar="KEY=V1,V2,...",
                   help="values of one configuration key; several --grid give the full grid")
    p.add_argument("--paired", action="store_true",
                   help="every grid point plays the same worlds (same seed): paired differences")
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("planes", help="perception-only study of the re-alignment's plane: every "
                       "first view of settled worlds, judged per grid point (no grasping)")
    p.add_argument("--setup", required=True, help="setup 1, 2 or 3 (or a list, e.g. 1,2,3)")
    p.add_argument("--objects", help="objects of the worlds, e.g. a,b,c (default a-f)")
    p.add_argument("--trials", type=int, default=100,
                   help="worlds per object (Setup 1) or rounds (Setups 2, 3); a run's first "
                        "attempts with the same seed")
    p.add_argument("--seed", type=int, default=0, help="base seed of every layout and key")
    p.add_argument("--preset", choices=["paper", "realistic"], default="paper")
    p.add_argument("--set", action="append", metavar="KEY=VALUE",
                   help="override a configuration value, e.g. procedure.view_tilt_deg=30")
    p.add_argument("--grid", action="append", metavar="KEY=V1,V2,...",
                   help="traced alignment values, e.g. align.window_px=5,15,30 (every "
                        "combination; one compiled program)")
    p.add_argument("--batch", type=int, help="worlds per chunk (default: 4096 per GPU, 32 on CPU)")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--overwrite", action="store_true", help="replace a study already in --out")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_planes)

    p = sub.add_parser("report", help="rebuild tables and figures from DIR/attempts.csv")
    p.add_argument("folder", help="a run or sweep output directory")
    p.add_argument("--debug", type=int, default=0, metavar="N",
                   help="also draw the first N saved attempts (views/) into DIR/debug/")
    p.set_defaults(func=cmd_report)

    p = sub.add_parser("bench", help="benchmarks (print numbers; compile time apart)")
    p.add_argument("what", choices=["perception", "detect", "physics", "pipeline"],
                   help="what to measure (detect: graspjax detect on real-looking images)")
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
    p.add_argument("--fast", action="store_true", help="GPU: allow non-deterministic XLA ops")
    p.add_argument("--preset", choices=["paper", "realistic"],
                   help="perception, physics, pipeline: configuration preset (default paper; "
                        "see graspjax run --help); detect takes --set only")
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

    XLA reads its flags once, when JAX starts its first backend; so this runs before any device
    is used, and importing graspjax must start none (tests/test_cli.py checks both). Called
    from Python after JAX has started (several runs in one process), it can only check: the
    CPU needs no flag, a GPU without it is refused.
    """
    if getattr(args, "fast", True):
        return
    import jax
    from jax._src import xla_bridge

    flag = "--xla_gpu_deterministic_ops=true"
    flags = os.environ.get("XLA_FLAGS", "")
    if flag in flags:
        return
    if not xla_bridge.backends_are_initialized():
        os.environ["XLA_FLAGS"] = f"{flags} {flag}".strip()
    elif jax.default_backend() == "gpu":
        raise UsageError("JAX started on the GPU without deterministic ops: set XLA_FLAGS="
                         f"{flag} before JAX starts, or pass --fast")


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        _deterministic_gpu(args)
        _compilation_cache()
        return args.func(args)
    except (InputError, ConfigError, UsageError) as exc:
        print(f"graspjax: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("graspjax: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
