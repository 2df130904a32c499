"""Command-line values checked and turned into requests, before anything compiles: numbers,
pixel boxes, intrinsics, jobs, grids, parts and the experiment a run or sweep asks for. A bad
value is a `UsageError` (one line; the command line prints it and exits with status 2).
"""

from __future__ import annotations

import math
import os
import re
import sys

from graspjax.disk import check_utf8_name, check_writable


class UsageError(Exception):
    """A bad combination of command-line arguments (one line)."""


def numbers(text: str, count: int, name: str) -> list[float]:
    """`count` finite numbers separated by commas or spaces, or a one-line error naming `name`."""
    parts = [p for p in re.split(r"[,\s]+", text.strip()) if p]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) != count or not all(math.isfinite(v) for v in values):
        raise UsageError(f"{name} takes {count} comma-separated numbers, got {text!r}")
    return values


def roi(text: str | None) -> tuple[int, int, int, int] | None:
    """--roi X0,Y0,X1,Y1 in whole pixels (its fit in the image is checked with the images)."""
    if text is None:
        return None
    values = numbers(text, 4, "--roi")
    if any(v != int(v) for v in values):
        raise UsageError(f"--roi takes whole pixels, got {text!r}")
    return tuple(int(v) for v in values)


def depth_range(text: str | None) -> tuple[float, float] | None:
    """--range MIN,MAX in metres, 0 <= MIN < MAX."""
    if text is None:
        return None
    lo, hi = numbers(text, 2, "--range")
    if not 0 <= lo < hi:
        raise UsageError(f"--range needs 0 <= MIN < MAX (metres), got {text!r}")
    return lo, hi


def intrinsics(args):
    """The one way the user gave intrinsics (`IntrinsicsRequest`); two ways at once is an error."""
    import numpy as np

    from graspjax.imagefiles.inputs import IntrinsicsRequest
    from graspjax.imagefiles.readers import check_matrix

    given = {"--fx/--fy/--cx/--cy": any(v is not None for v in (args.fx, args.fy, args.cx, args.cy)),
             "--K": args.K is not None, "--intrinsics": args.intrinsics is not None,
             "--fov-x/--fov-y": args.fov_x is not None or args.fov_y is not None}
    chosen = [name for name, used in given.items() if used]
    if len(chosen) > 1:
        raise UsageError(f"give the intrinsics one way, not {' and '.join(chosen)}")
    if given["--fx/--fy/--cx/--cy"]:
        if args.fx is None:
            raise UsageError("--fy, --cx and --cy need --fx")
        fy = args.fx if args.fy is None else args.fy
        if args.fx <= 0 or fy <= 0:
            raise UsageError("focal lengths must be > 0")
        return IntrinsicsRequest(focal=(args.fx, fy), centre=(args.cx, args.cy),
                                 source="--fx {fx:g} --fy {fy:g} --cx {cx:g} --cy {cy:g}")
    if given["--K"]:
        k = check_matrix(np.reshape(numbers(args.K, 9, "--K"), (3, 3)), "--K")
        return IntrinsicsRequest(focal=(k[0, 0], k[1, 1]), centre=(k[0, 2], k[1, 2]), source="--K")
    if given["--intrinsics"]:
        return IntrinsicsRequest(file=args.intrinsics, source=args.intrinsics)
    if given["--fov-x/--fov-y"]:
        return IntrinsicsRequest(fov_deg=(args.fov_x, args.fov_y), source="--fov-x/--fov-y")
    return IntrinsicsRequest()


def detect_settings(preset_name: str | None, top: int | None, sets: list[str] | None,
                    method: str | None = None) -> list[str]:
    """`--set` items of a detect command: its preset's, then --top and --method, then the
    user's own."""
    from graspjax.config import PRESETS, parse_assignments

    if top is not None and top < 1:
        raise UsageError(f"--top must be >= 1, got {top}")
    flags = [f"image.top_k={top}"] if top is not None else []
    flags += [f"method={method}"] if method is not None else []
    parse_assignments(flags + (sets or []))  # malformed, or a key given twice: an error
    items = [f"{k}={v}" for k, v in PRESETS[preset_name or "paper"].items()]
    return items + flags + (sets or [])


def ints(text: str, name: str, allowed) -> tuple[int, ...]:
    try:
        values = tuple(int(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise UsageError(f"{name} takes comma-separated integers, got {text!r}") from None
    bad = [v for v in values if v not in allowed]
    if bad or not values:
        raise UsageError(f"{name} must be among {', '.join(map(str, allowed))}, got {text!r}")
    if len(set(values)) < len(values):
        raise UsageError(f"{name} names a value twice: {text!r}")
    return values


def jobs(args):
    """Jobs from --table or --setup/--objects, validated (no compilation yet)."""
    from graspjax.batch.plan import MAX_BATCH, MAX_SEED, Job, table_job
    from graspjax.sim.objects import parse_letters

    if args.trials < 1:
        raise UsageError(f"--trials must be >= 1, got {args.trials}")
    if not 0 <= args.seed <= MAX_SEED:
        raise UsageError(f"--seed must be in [0, {MAX_SEED}], got {args.seed}")
    if args.batch is not None and not 1 <= args.batch <= MAX_BATCH:
        raise UsageError(f"--batch must be in [1, {MAX_BATCH}] worlds per device call, got "
                         f"{args.batch}")
    if getattr(args, "max_views", 0) < 0:
        raise UsageError(f"--max-views must be >= 0, got {args.max_views}")
    if getattr(args, "resume", False) and args.overwrite:
        raise UsageError("give --resume or --overwrite, not both")
    part(getattr(args, "part", None))
    table = getattr(args, "table", None)  # `planes` has no --table
    if (table is None) == (args.setup is None):
        raise UsageError("give either --table 1|2|1,2 or --setup S [--objects ...]")
    if table is not None:
        if args.objects is not None:
            raise UsageError("--objects goes with --setup; the tables fix their objects")
        return [table_job(t, args.trials) for t in ints(table, "--table", (1, 2))]
    try:
        objects = parse_letters("abcdef" if args.objects is None else args.objects)
    except ValueError as exc:
        raise UsageError(f"--objects: {exc}") from None
    return [Job(objects, ints(args.setup, "--setup", (1, 2, 3)), args.trials)]


def grid(items: list[str], base, fixed=()):
    """--grid key=v1,v2,... -> (keys, list of (values dict, config)); every point validated,
    none twice, no key twice nor among the `fixed` keys of --set.

    Keys joined by ':' vary together: --grid camera.width:camera.height=80:60,160:120.
    """
    import itertools

    from graspjax.config import override, parse_assignments

    axes = []
    for name, text in parse_assignments(items).items():
        names = name.split(":")
        if len(set(names)) < len(names):
            raise UsageError(f"--grid {name} names {next(n for n in names if names.count(n) > 1)} "
                             "twice")
        values = [v.strip().split(":") for v in text.split(",") if v.strip()]
        if not values:
            raise UsageError(f"--grid {name}= has no values")
        if any(len(v) != len(names) for v in values):
            raise UsageError(f"--grid {name}: every value needs {len(names)} parts joined by ':'")
        axes.append([dict(zip(names, v, strict=True)) for v in values])
    keys = [k for axis in axes for k in axis[0]]
    _refuse_detect_settings(keys, "--grid {}: a")
    twice = sorted({k for k in keys if keys.count(k) > 1} | (set(keys) & set(fixed)))
    if twice:
        raise UsageError(f"{twice[0]} is given twice (in two --grid, or in --grid and --set or "
                         "--config)")
    points = []
    for combo in itertools.product(*axes):
        assignment = {k: v for part in combo for k, v in part.items()}
        points.append((assignment, override(base, assignment)))
    for i, (assignment, config) in enumerate(points):
        for earlier, other in points[:i]:
            if other == config:
                raise UsageError(f"--grid gives one point twice ({_point(earlier)} and "
                                 f"{_point(assignment)}): its seeds would be pooled as one cell")
    return keys, points


def _point(assignment: dict) -> str:
    return ", ".join(f"{k}={v}" for k, v in assignment.items())


def part(text: str | None) -> tuple[int, int]:
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


def _refuse_detect_settings(keys, said: str) -> None:
    """A simulated run's settings hold no `image.*` key (`Config.image`: graspjax detect's
    alone); the first one found is refused, `said` the message's opening ({} the key)."""
    for key in keys:
        if key.startswith("image."):
            raise UsageError(said.format(key) + " setting of graspjax detect (real depth images); "
                             "a simulated run does not read it")


def settings(args):
    """A run's, sweep's or plane study's configuration: its preset with the settings of
    `--config FILE`, `--method` and every `--set` applied, a key given by two of them an error.
    Returns (config, the keys of --config and --set (key -> value text), what config.json
    records of the file: {"path", "settings"}, or None without --config)."""
    from graspjax.config import ConfigError, override, parse_assignments, preset, settings_file

    method = [f"method={args.method}"] if getattr(args, "method", None) else []
    given = parse_assignments(method + (args.set or []))
    path = args.config
    from_file = settings_file(path) if path else {}
    twice = [key for key in given if key in from_file]
    if twice:
        raise UsageError(f"{twice[0]} is given twice (in --config {path} and on the command line)")
    _refuse_detect_settings([*given, *from_file], "{} is a")
    base = preset(args.preset)
    try:
        config = override(base, {**from_file, **given})
    except ConfigError:
        if from_file:  # the file's own mistake names the file
            try:
                override(base, from_file)
            except ConfigError as exc:
                raise ConfigError(f"--config {path}: {exc}") from None
        raise
    fixed = {**from_file, **parse_assignments(args.set or [])}
    return config, fixed, {"path": path, "settings": from_file} if path else None


def experiment_request(args, grid_items):
    """The checked `Experiment` of a run (no grid) or sweep, before anything compiles."""
    from graspjax.experiment import Experiment

    config, fixed, config_file = settings(args)
    keys, points = (([], [({}, config)]) if grid_items is None
                    else grid(grid_items, config, fixed))
    checked = jobs(args)
    paired = getattr(args, "paired", False)
    sweep_seeds(args.seed, len(points), paired)
    return Experiment(jobs=checked, base=config, points=points, keys=keys, seed=args.seed,
                      batch=args.batch, paired=paired, preset=args.preset,
                      save_views=args.save_views, max_views=args.max_views,
                      deterministic=not args.fast, config_file=config_file,
                      reuse=getattr(args, "reuse", None))


def sweep_seeds(seed: int, points: int, paired: bool) -> None:
    """A sweep's seeds within range: point i has seed `seed + i` (`batch.plan.plan`), or every
    point `seed` when `paired` (`seed` itself is checked with the jobs)."""
    from graspjax.batch.plan import MAX_SEED

    last = seed if paired else seed + points - 1
    if last > MAX_SEED:
        raise UsageError(f"--seed {seed}: the sweep's {points} points take seeds {seed} to "
                         f"{last} (point i: seed + i), past the largest seed {MAX_SEED}; give "
                         f"--seed <= {MAX_SEED - points + 1}, or --paired")


def detect_request(args):
    """`graspjax detect`'s checked request: (inputs, outputs, batch (None: the device's
    default, `batches.default_image_batch`), several images)."""
    from graspjax.experiment import DetectOutputs
    from graspjax.imagefiles.inputs import expand_images, prepare

    many = len(expand_images(args.images)) > 1
    if args.figure and many:
        raise UsageError("--figure takes one image; give --figures DIR for several")
    if args.batch is not None and args.batch < 1:
        raise UsageError(f"--batch must be >= 1, got {args.batch}")
    if args.downsample is not None and args.downsample < 1:
        raise UsageError(f"--downsample must be >= 1, got {args.downsample}")
    if not (args.depth_scale > 0 and math.isfinite(args.depth_scale)):
        raise UsageError(f"--depth-scale must be > 0, got {args.depth_scale!r}")
    to_csv = args.out is not None and args.out.lower().endswith(".csv")
    outputs = DetectOutputs(json=args.json, figure=args.figure, figures=args.figures,
                            csv=args.out if to_csv else None,
                            folder=args.out if args.out and not to_csv else None)
    files = {}  # each output file's own path (a folder may take --out's and --figures'): one
    # written over another is lost
    for path, what, folder in ((outputs.json, "--json", False), (outputs.figure, "--figure", False),
                               (outputs.csv, "--out", False), (outputs.folder, "--out", True),
                               (outputs.figures, "--figures", True)):
        check_writable(path, what, directory=folder)
        if path is not None:
            key = os.path.abspath(path)
            if key in files and not (folder and files[key][1]):
                raise UsageError(f"{files[key][0]} and {what} name the same path {path}: give "
                                 "each its own")
            files[key] = (what, folder)
    inputs = prepare(args.images, depth_scale=args.depth_scale, intrinsics=intrinsics(args),
                     camera_pose=args.camera_pose,
                     roi=roi(args.roi), mask=args.mask, depth_range=depth_range(args.range),
                     downsample=args.downsample, bin=args.bin,
                     overrides=detect_settings(args.preset, args.top, args.set, args.method),
                     warn=lambda line: print(f"graspjax: warning: {line}", file=sys.stderr))
    return inputs, outputs, args.batch, many


def bench_request(args) -> dict:
    """`graspjax bench`'s checked request: the keyword arguments of `bench.measure`."""
    from graspjax.config import override, preset
    from graspjax.imagefiles.inputs import split_overrides
    from graspjax.sim.objects import parse_letters

    check_writable(args.out, "--out")
    if args.profile is not None and args.what not in ("pipeline", "detect"):
        raise UsageError("--profile is for bench pipeline and bench detect")
    check_writable(args.profile, "--profile", directory=True)
    if args.batch is not None and args.batch < 1 or args.repeats < 1:
        raise UsageError("--batch and --repeats must be >= 1")
    for name, value in (("--width", args.width), ("--height", args.height)):
        if value is not None and value < 16:
            raise UsageError(f"{name} must be >= 16 pixels, got {value}")
    if args.trials < 1:
        raise UsageError(f"--trials must be >= 1, got {args.trials}")
    if not (math.isfinite(args.seconds) and args.seconds > 0):
        raise UsageError(f"--seconds must be a positive number, got {args.seconds:g}")
    if args.what == "detect":  # configured as graspjax detect is
        config, image = split_overrides(detect_settings(args.preset, None, args.set))
    else:
        config, image = override(preset(args.preset or "paper"), args.set or []), None
    try:
        letters = "".join(parse_letters(args.objects))
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    if args.what == "finish":
        if args.rows_from is None:
            raise UsageError("bench finish needs --rows-from FOLDER, a finished run's folder")
        if args.rows < 1:
            raise UsageError(f"--rows must be >= 1, got {args.rows}")
        try:
            from graspjax.report import load_attempts
            if "chunk" not in load_attempts(args.rows_from).columns:
                raise ValueError(f"{args.rows_from}'s rows have no chunk column")
        except (OSError, ValueError) as exc:
            raise UsageError(f"--rows-from: {exc}") from None
        from pathlib import Path

        from graspjax.bench_finish import ROWS_FROM
        from graspjax.outputs import read_run_config
        read_run_config(Path(args.rows_from) / "config.json", ROWS_FROM)  # before anything is timed
    return dict(config=config, image=image, objects=letters,
                setups=ints(str(args.setup), "--setup", (1, 2, 3)), trials=args.trials,
                seconds=args.seconds, batch=args.batch, width=args.width, height=args.height,
                repeats=args.repeats, profile=args.profile)


def plane_request(args):
    """`graspjax planes`' checked request: (jobs, config, points, keys, the --config file's
    record (`settings`)); the grid may vary only traced alignment values, so that every point
    shares one compiled program."""
    import jax

    config, fixed, config_file = settings(args)
    keys, points = grid(args.grid, config, fixed) if args.grid else ([], [({}, config)])
    bad = [k for k in keys if not k.startswith("align.")]
    if bad or any(jax.tree.structure(c) != jax.tree.structure(config) for _, c in points):
        raise UsageError("planes --grid takes traced align.* values that compile once (e.g. "
                         f"align.window_px, align.distance_threshold), got {', '.join(keys)}")
    return jobs(args), config, points, keys, config_file


def distributed(text: str | None, part: str | None):
    """--distributed [HOST:PORT,N,I] -> None (not given), `distributed.AUTO` (the launcher's
    environment) or (coordinator address, process count, this process's index)."""
    from graspjax.runtime.distributed import AUTO

    if text is None:
        return None
    if part is not None:
        raise UsageError("give --distributed or --part, not both")
    if text == AUTO:
        return AUTO
    fields = text.split(",")
    try:
        address, count, index = fields[0], int(fields[1]), int(fields[2])
    except (IndexError, ValueError):
        raise UsageError(f"--distributed takes HOST:PORT,N,I (or nothing), got {text!r}") from None
    if len(fields) != 3 or ":" not in address or not 0 <= index < count:
        raise UsageError(f"--distributed HOST:PORT,N,I needs 0 <= I < N, got {text!r}")
    host, _, port = address.rpartition(":")
    if not host or not port.isdigit() or not 0 < int(port) < 65536:
        raise UsageError(f"--distributed HOST:PORT,N,I needs a port 1-65535 after the host, "
                         f"got {text!r}")
    return address, count, index


def report_folder(args):
    """`graspjax report`'s checked folder (a Path), or with --compare its checked folders (a
    list); --debug checked too."""
    from pathlib import Path

    from graspjax.errors import InputError

    if (args.folder is None) == (args.compare is None):
        raise UsageError("give a folder to report, or --compare DIR ... (not both)")
    if args.compare is not None and args.debug:
        raise UsageError("--debug draws one folder's attempts: not with --compare")
    folders = [Path(f) for f in (args.compare or [args.folder])]
    for folder in folders:
        if not folder.is_dir():
            raise InputError(f"no such directory: {folder}")
        if args.compare is not None:  # the comparison's columns are named by the folders
            check_utf8_name(folder, "the folder's name")
    if args.debug < 0:
        raise UsageError(f"--debug must be >= 0, got {args.debug}")
    return folders if args.compare is not None else folders[0]
