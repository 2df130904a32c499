"""The `graspjax` command line: arguments parsed (`parser.py`), checked into requests
(`arguments.py`), the work handed to `experiment` (run, sweep, planes, detect), `report` or
`bench`, what they return printed.

User mistakes (missing files, bad values, unknown keys) print one line to
stderr and exit with status 2; nothing is written unless everything worked.
"""

from __future__ import annotations

import json
import os
import sys

from graspjax import arguments
from graspjax.arguments import UsageError
from graspjax.config import ConfigError
from graspjax.disk import check_writable
from graspjax.errors import InputError
from graspjax.parser import build_parser
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
    from graspjax.runtime import players

    request = arguments.experiment_request(args, grid_items)
    processes = 1 if spec else players.count(args.processes)  # checked by a dry run too
    if args.dry_run:
        def lines() -> list[str]:
            groups, reused = experiment.planned_groups(request)
            return [*reused, *estimate.plan_lines(groups, len(request.points), request.batch)]
        return _dry_run(args, lines)
    try:
        result = experiment.run(request, args.out, args.resume, args.overwrite, part, parts,
                                args.quiet, processes, distributed=spec is not None,
                                compile_first=args.compile_first)
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
    compiled or written, and a folder a real run would refuse (`check_output_folder`) is refused
    now; whether a folder given --resume holds this same run is checked by the run alone."""
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
    if isinstance(folder, list):
        return _compare(folder)
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


def _compare(folders) -> int:
    """`graspjax report --compare`: the paired table on stdout (`report.compare`)."""
    from graspjax.report.compare import compared_rows, comparison_table

    try:
        frame, names = compared_rows(folders)
    except (FileNotFoundError, ValueError) as exc:
        raise InputError(str(exc).splitlines()[0]) from None
    except KeyError as exc:
        raise InputError(f"the rows lack the column {exc} a comparison needs") from None
    print(f"Paired against {names[0]} (each object of a trial or round; z: McNemar's; "
          "resolves: the smallest change its pairs detect at 5 %, 80 % power)\n")
    print(comparison_table(frame, names), end="")
    return 0


COMMANDS = {"detect": cmd_detect, "run": cmd_run, "sweep": cmd_sweep, "planes": cmd_planes,
            "config": cmd_config, "report": cmd_report, "assets": cmd_assets, "bench": cmd_bench}


def main(argv: list[str] | None = None) -> int:
    from graspjax.provenance import command

    argv = sys.argv[1:] if argv is None else list(argv)
    args = build_parser().parse_args(argv)
    try:
        from graspjax.runtime import xla

        problem = xla.set_up(deterministic=not getattr(args, "fast", True))
        if problem:
            raise UsageError(problem)
        with command(argv):  # recorded as typed (config.json's "command")
            return COMMANDS[args.command](args)
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
        print(f"graspjax: error: {exc.strerror or exc}{where}{resumable(args)}", file=sys.stderr)
        return 1
    except RuntimeError as exc:  # JAX's XlaRuntimeError: a batch larger than the device holds
        shortage = out_of_memory(exc)
        if shortage is None:
            raise
        print(f"graspjax: error: the device ran out of memory ({shortage}); a smaller --batch "
              f"needs less{resumable(args)}", file=sys.stderr)
        return 1


def resumable(args) -> str:
    """What a simulated run keeps when it stops on an error (its commands take --resume)."""
    if not hasattr(args, "resume"):
        return ""
    return " (a run keeps every chunk it finished: --resume continues it)"


def out_of_memory(exc: RuntimeError) -> str | None:
    """The first sentence of XLA's message when `exc` is its RESOURCE_EXHAUSTED (an allocation
    the device could not make), else None."""
    text = str(exc)
    if "RESOURCE_EXHAUSTED:" not in text:
        return None
    detail = text.split("RESOURCE_EXHAUSTED:", 1)[1].split("[", 1)[0].strip()
    return (detail.splitlines() or ["out of memory"])[0].rstrip(".")


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
