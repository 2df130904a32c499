"""The `graspjax` command line: arguments parsed, checked into requests (`arguments.py`), the
work handed to `experiment` (run, sweep, planes, detect), `report` or `bench`, what they
return printed.

User mistakes (missing files, bad values, unknown keys) print one line to
stderr and exit with status 2; nothing is written unless everything worked.
"""

from __future__ import annotations

import argparse
import json
import os
import sys

from graspjax import arguments
from graspjax.arguments import UsageError
from graspjax.config import METHODS, ConfigError
from graspjax.disk import check_writable
from graspjax.io import InputError
from graspjax.runtime import distributed


def cmd_detect(args) -> int:
    """Detect grasps on depth images from disk: one JSON record each, or a table of many."""
    from graspjax.experiment import detect_images
    from graspjax.imagefiles.records import line

    inputs, outputs, batch, many = arguments.detect_request(args)
    records = detect_images(inputs, outputs, batch, args.quiet)
    if many:
        for rec in records:
            print(line(rec))
        print(f"{sum(r['found'] for r in records)} of {len(records)} images with a grasp")
    else:
        print(json.dumps(records[0], indent=2))
    return 0


def cmd_bench(args) -> int:
    """A benchmark: print its summary, and write its record with --out."""
    request, said = arguments.bench_request(args), lambda m: print(m, file=sys.stderr)
    if args.what == "finish":
        from graspjax.bench_finish import finish_benchmark, format_finish

        result = finish_benchmark(args.rows_from, args.rows, said)
        text = format_finish(result)
    else:
        from graspjax.bench import measure

        result, text = measure(args.what, **request, progress=said)
    if args.out:
        from graspjax.disk import jsonable, write_atomic

        write_atomic(args.out, (json.dumps(jsonable(result), indent=2) + "\n").encode())
    print(text)
    return 0


def _run_experiment(args, grid_items=None) -> int:
    from graspjax.runtime import xla

    part, parts = arguments.part(args.part)
    spec = arguments.distributed(args.distributed, args.part)
    if spec is not None:
        distributed.initialize(spec)  # before any device starts
    xla.start_devices()
    from graspjax import experiment
    from graspjax.batch import estimate

    request = arguments.experiment_request(args, grid_items)
    if args.dry_run:
        return _dry_run(args, lambda: estimate.plan_lines(experiment.planned_groups(request),
                                                           len(request.points), request.batch))
    from graspjax.runtime import players

    try:
        result = experiment.run(request, args.out, args.resume, args.overwrite, part, parts,
                                args.quiet, 1 if spec else players.count(args.processes),
                                distributed=spec is not None, compile_first=args.compile_first)
        distributed.shutdown()
    except players.HelperFailed as exc:
        print(f"graspjax: error: {exc} (the finished chunks are kept: the same command with "
              "--resume continues)", file=sys.stderr)
        return 1
    if not result.files and spec is not None:
        print(f"this process's chunks are done; process 0 writes the results to {result.folder}")
        return 0
    if not result.files:
        print(f"part {part}/{parts} done; {result.chunks_done} of {result.chunks} chunks of the "
              f"run are done in {result.folder} (the part that completes the last chunk writes "
              "the results)")
        return 0
    print(f"{result.attempts} attempts, success {result.success_rate:.1%}; wrote "
          + ", ".join(p.name for p in result.files) + f" to {result.folder}")
    before = "before: from the interpreter's start; " if "before" in result.seconds else ""
    print("seconds: " + ", ".join(f"{phase} {s:.1f}" for phase, s in result.seconds.items())
          + f" ({before}chunks: programs loaded or compiled, and played)")
    for name in ("table1.md", "table2.md"):
        if (result.folder / name).exists() and grid_items is None:
            print((result.folder / name).read_text())
    return 0


def _dry_run(args, lines) -> int:
    """--dry-run: print `lines()` (what would be played, `batch.estimate`); nothing is traced,
    compiled or written, and a folder a real run would refuse is refused now."""
    from graspjax.outputs import check_output_folder

    check_output_folder(args.out, getattr(args, "resume", False), args.overwrite)
    print("\n".join(lines()))
    return 0


def cmd_run(args) -> int:
    """Run grasp attempts and write attempts, tables and figures."""
    return _run_experiment(args)


def cmd_sweep(args) -> int:
    """Run a full parameter grid; every point has its own seed (seed + point index), or with
    --paired the same seed (the same worlds)."""
    if not args.grid:
        raise UsageError("sweep needs at least one --grid key=v1,v2,...")
    return _run_experiment(args, args.grid)


def cmd_planes(args) -> int:
    """Perception-only plane study: settle worlds, take each first view, judge the
    re-alignment's plane for every grid point of traced alignment values."""
    from graspjax.batch import estimate
    from graspjax.experiment import plane_study

    jobs, config, points, keys, config_file = arguments.plane_request(args)
    if args.dry_run:
        return _dry_run(args, lambda: estimate.plane_plan_lines(jobs, config, len(points),
                                                                 args.seed, args.batch))
    summary, timings, out = plane_study(jobs, config, points, keys, args.seed, args.batch,
                                        args.preset, args.out, args.overwrite, args.quiet,
                                        config_file)
    print(summary.to_string(index=False, float_format=lambda x: f"{x:.3g}"))
    print(f"{timings['views_scored']:,} views scored in {timings['score_s']:.2f} s "
          f"({timings['views_per_s']:,.0f} views/s; compile {timings['score_compile_s']:.1f} s, "
          f"settle {timings['settle_s']:.1f} s, first views {timings['view_s']:.1f} s); wrote "
          f"planes.csv.gz, planes_summary.csv, planes.png, config.json to {out}")
    return 0


def cmd_assets(args) -> int:
    """Write the objects' meshes, MJCF files and catalogue (the committed `assets/objects/`)."""
    from graspjax.sim.objects import write_assets

    check_writable(args.folder, "folder", directory=True)
    for path in write_assets(args.folder):
        print(path)
    return 0


def cmd_config(args) -> int:
    """List the configuration keys: default per preset, unit, traced or static, meaning."""
    import csv

    from graspjax.config import PRESETS, keys

    presets = [args.preset] if args.preset else list(PRESETS)
    found = keys(presets, args.prefix)
    if args.format == "json":
        print(json.dumps([{"key": k.name, "defaults": k.defaults, "unit": k.unit,
                           "kind": "traced" if k.traced else "static", "meaning": k.meaning}
                          for k in found], indent=1))
        return 0
    rows = [["key", *presets, "unit", "kind", "meaning"]]
    rows += [[k.name, *(_setting(k.defaults[p]) for p in presets), k.unit,
              "traced" if k.traced else "static", k.meaning] for k in found]
    if args.format == "csv":
        csv.writer(sys.stdout, lineterminator="\n").writerows(rows)
        return 0
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]) - 1)]
    for row in rows:
        print("  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=False)) + "  " + row[-1])
    return 0


def _setting(value) -> str:
    """A default as `--set` takes it (`true`, not `True`)."""
    return str(value).lower() if isinstance(value, bool) else str(value)


def cmd_report(args) -> int:
    from graspjax.provenance import made_by_other_code
    from graspjax.report import read_meta, write_report

    folder = arguments.report_folder(args)
    other = made_by_other_code(read_meta(folder))
    if other:  # its rows stand; tables and figures drawn by this code may differ in form
        print(f"graspjax: note: {folder} was {other}: its rows are kept, its tables and figures "
              "are rebuilt by this code", file=sys.stderr)
    try:
        files, state = write_report(folder, debug=args.debug)
    except (FileNotFoundError, ValueError) as exc:
        raise InputError(str(exc).splitlines()[0]) from None
    except KeyError as exc:
        raise InputError(f"{folder}: attempts.csv lacks the column {exc} the report needs") from None
    except OSError as exc:
        raise InputError(f"cannot write the report into {folder}: {exc.strerror or exc}") from None
    if state:
        print(f"graspjax: note: {folder} holds a run not yet finished ({state}); its tables "
              "say so in their titles", file=sys.stderr)
    print("wrote " + ", ".join(str(p.relative_to(folder)) for p in files) + f" to {folder}")
    return 0


CONFIG_HELP = ("settings file: the dotted keys of --set with their values, in TOML ([align] "
               "window_px = 12, or align.window_px = 12) or YAML (with PyYAML); a key may not "
               "be given by --set as well (keys: graspjax config)")


def _add_experiment_arguments(p) -> None:
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


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="graspjax",
        description="Batch evaluator of double T-beam grasp detection and plane-detection "
                    "end-tool alignment (JAX / MuJoCo MJX).")
    sub = parser.add_subparsers(dest="command", required=True)

    arguments.add_detect_parser(sub).set_defaults(func=cmd_detect)

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
    p.set_defaults(func=cmd_planes)

    p = sub.add_parser("config", help="list the configuration keys --set takes: default per "
                       "preset, unit, traced (a sweep compiles once) or static, meaning")
    p.add_argument("prefix", nargs="?", default="", metavar="PREFIX",
                   help="only the keys that start with this, e.g. align.")
    p.add_argument("--preset", choices=["paper", "realistic"],
                   help="only this preset's defaults (default: every preset's)")
    p.add_argument("--format", choices=["text", "csv", "json"], default="text",
                   help="aligned text (default), CSV or JSON")
    p.set_defaults(func=cmd_config)

    p = sub.add_parser("report", help="rebuild tables and figures from DIR/attempts.csv")
    p.add_argument("folder", help="a run or sweep output directory")
    p.add_argument("--debug", type=int, default=0, metavar="N",
                   help="also draw the first N saved attempts (views/) into DIR/debug/")
    p.set_defaults(func=cmd_report)

    p = sub.add_parser("assets", help="write the objects' meshes and MJCF files (assets/objects)")
    p.add_argument("folder", nargs="?", default="assets/objects", help="output folder")
    p.set_defaults(func=cmd_assets)

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
    p.add_argument("--fast", action="store_true", help="GPU: allow non-deterministic XLA ops")
    p.add_argument("--preset", choices=["paper", "realistic"],
                   help="configuration preset (default paper; see graspjax run --help; "
                        "detect: as graspjax detect --preset)")
    p.add_argument("--set", action="append", metavar="KEY=VALUE")
    p.set_defaults(func=cmd_bench)
    return parser


def main(argv: list[str] | None = None) -> int:
    from graspjax.provenance import command

    argv = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        from graspjax.runtime import xla

        problem = xla.set_up(deterministic=not getattr(args, "fast", True))
        if problem:
            raise UsageError(problem)
        with command(argv):  # recorded as typed (config.json's "command")
            return args.func(args)
    except (InputError, ConfigError, UsageError) as exc:
        print(f"graspjax: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("graspjax: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # its reader stopped reading (`graspjax config | head`): no error
        return 0
    except OSError as exc:  # a write failed: a full disk, a read-only folder, a file size limit
        where = f": {exc.filename}" if exc.filename else ""
        print(f"graspjax: error: {exc.strerror or exc}{where} (a run keeps every chunk it "
              "finished: --resume continues it)", file=sys.stderr)
        return 1


def entry() -> None:
    """The `graspjax` command: `main`, then the process ends without the interpreter's teardown
    (every file is written and closed by then): tearing down JAX's GPU client and the programs
    loaded on it is a noticeable share of a warm run (results/benchmarks)."""
    code = main()  # an exception (argparse's SystemExit, a bug's traceback) ends it as usual
    try:
        sys.stdout.flush()
        sys.stderr.flush()
    finally:  # a closed pipe (`| head`) must not keep the exit code from the shell
        os._exit(code)


if __name__ == "__main__":
    entry()
