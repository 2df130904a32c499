"""The workflows that turn a checked command into files: a simulated run or sweep, a plane
study, and a detection on real depth images.

Each reads top to bottom: plan the work, write what identifies it, run the compiled kernels
chunk by chunk (`batch.program`, `planes`, `imagefiles.batches`), turn their records into rows
or records (`batch.rows`, `imagefiles.records`), write them as they come (`outputs`), then the
report computed from the written rows alone (`report`). The command line parses and checks
the arguments and prints what these return.
"""

from __future__ import annotations

import dataclasses
import functools
import gzip
import importlib
import json
import os
import sys
import threading
import time
from pathlib import Path

import pandas as pd

from graspjax.batch import estimate
from graspjax.batch.plan import Group, Job, chunks, default_batch, plan, share
from graspjax.batch.program import program
from graspjax.batch.rows import RunColumns, attempt_rows, round_rows
from graspjax.batch.schedule import run_chunks
from graspjax.config import Config, differences, run_settings
from graspjax.disk import jsonable, write_atomic
from graspjax.outputs import RunFolder, check_output_folder, remove_own_files, run_id, writing
from graspjax.provenance import process_age, provenance
from graspjax.runtime.compiles import trace_workers
from graspjax.runtime.distributed import barrier
from graspjax.runtime.distributed import process as process_of_run
from graspjax.runtime.players import Assignment, Helper, cores_of, kept_to


def progress_bar(total: int, quiet: bool, initial: int = 0, unit: str = "attempt",
                 show_bar: bool = True):
    """A progress bar on stderr (none with `quiet`, without `show_bar` or with a `total` of 0:
    every row copied) and a `log(message)` that prints above it (nothing with `quiet`)."""
    from tqdm import tqdm

    bar = tqdm(total=total, initial=initial, unit=unit, disable=quiet or not show_bar or not total,
               dynamic_ncols=True, file=sys.stderr, smoothing=0.05)
    return bar, (lambda message: None) if quiet else (lambda message: bar.write(message, file=sys.stderr))


@functools.cache
def import_in_background(module: str) -> None:
    """Start importing `module` in a thread, once per process: the report's plotting libraries
    load while the device plays the next chunk rather than before the first. A later import
    waits for it (the import system locks the module) and raises its error, if any."""
    if module not in sys.modules:
        threading.Thread(target=importlib.import_module, args=(module,), daemon=True,
                         name=f"import {module}").start()


@dataclasses.dataclass(frozen=True)
class Experiment:
    """One `graspjax run` (a grid of one point) or `sweep`, as the command line checked it."""

    jobs: list[Job]
    base: Config  # the preset with every --set applied
    points: list[tuple[dict[str, str], Config]]  # grid point i: its --grid values and config
    keys: list[str]  # the grid's dotted keys ([] for a plain run)
    seed: int
    batch: int | None  # worlds per chunk (None: device-sized)
    paired: bool  # every grid point plays the same worlds
    preset: str
    save_views: str  # none, failed or all
    max_views: int
    deterministic: bool  # XLA's deterministic GPU ops (not --fast)
    config_file: dict | None = None  # --config: {"path", "settings" (key -> value text)}
    reuse: str | None = None  # --reuse: a finished run whose worlds a paired study shares

    @property
    def sweep(self) -> bool:
        return bool(self.keys)


@dataclasses.dataclass(frozen=True)
class RunResult:
    """What a finished run (or one part of a shared run) wrote."""

    folder: Path
    files: list[Path]  # [] while other parts of a shared run are missing
    chunks_done: int
    chunks: int
    attempts: int  # rows of attempts.csv (0 while parts are missing)
    success_rate: float  # their mean success (nan while parts are missing)
    seconds: dict[str, float] = dataclasses.field(default_factory=dict)  # where the run's time
    # went: "before" (from the interpreter's start: imports, the devices' start; Linux only),
    # "start" (planning, the folder, until the chunks began), "chunks" (until the last was
    # kept), "rows" (the sorted attempts, rounds, timings), "report" (tables, figures)


def run(experiment: Experiment, out: str | Path, resume: bool = False, overwrite: bool = False,
        part: int = 0, parts: int = 1, quiet: bool = False, processes: int = 1,
        distributed: bool = False, compile_first: bool = False) -> RunResult:
    """Run an experiment into the folder `out` (`outputs.RunFolder`), chunk by chunk, then
    write its report. With `parts` > 1 this process runs every `parts`-th chunk from `part`
    into a folder shared with the other parts; the one that completes the last chunk writes
    the results. With `distributed` (`runtime.distributed.initialize` done), the part and the
    parts are this process's index and the process count of JAX's distributed runtime: process
    0 sets the folder up, every process plays its chunks, and once all have, process 0 writes
    the results (the others return none). With `processes` > 1 (CPU) helper processes play
    some of its groups side by side with it (`plan.share`, `runtime.players`; not while views
    are kept). With `compile_first`, every program is ready on every device before this
    process's first chunk (`batch.schedule.run_chunks` without overlap)."""
    trace_workers()  # a bad GRASPJAX_TRACE_WORKERS stops the run before it writes anything
    reused = _reused(experiment)  # and so does a run that --reuse refuses
    if distributed:
        part, parts = process_of_run()
    if part == 0 or not distributed:  # distributed: process 0 alone checks (and overwrites)
        out = check_output_folder(out, resume or parts > 1 and not distributed, overwrite)
    with writing(Path(out), shared=parts > 1):  # one process writes a folder (parts: several)
        return _run(experiment, Path(out), resume, part, parts, quiet, processes, distributed,
                    compile_first, reused)


def run_meta(experiment: Experiment, batch: int, reused=None) -> dict:
    """What a run's config.json holds at its start: its id (`outputs.run_id`: the same for
    the same settings, however given), every setting, what --config gave, the run it reuses
    (`reused`: a `reuse.Reused`), the provenance."""
    meta = {"seed": experiment.seed, "paired": experiment.paired, "preset": experiment.preset,
            "jobs": [dataclasses.asdict(j) for j in experiment.jobs],
            "overrides": differences(experiment.base, Config()),
            "config_file": experiment.config_file,
            "grid": {k: [p[0][k] for p in experiment.points] for k in experiment.keys},
            "points": len(experiment.points),
            "config": run_settings(experiment.base),
            "batch": batch, "deterministic": experiment.deterministic,
            "xla_flags": os.environ.get("XLA_FLAGS", ""), "save_views": experiment.save_views,
            **({"reuse": {"folder": str(Path(experiment.reuse).resolve()), "run_id": reused.run_id}}
               if reused else {}),
            **provenance()}
    return {"run_id": run_id(meta), **meta}


def _run(experiment: Experiment, out: Path, resume: bool, part: int, parts: int, quiet: bool,
         processes: int, distributed: bool, compile_first: bool, reused) -> RunResult:
    """`run`, with the folder checked and locked (`reused`: `_reused`)."""
    from graspjax.saved_views import ViewSaver

    clock = [time.perf_counter()]  # the ends of the run's phases (`RunResult.seconds`)
    before = process_age()

    batch = experiment.batch or default_batch()
    configs, groups = _grouped(experiment, reused)
    planned = chunks(groups, batch)
    copied = reused.copied_points(configs) if reused else []  # chunks len(planned) + i
    meta = run_meta(experiment, batch, reused)
    columns = RunColumns(meta["run_id"], configs, experiment.keys, experiment.base)
    ours = [c for c in planned if c.index % parts == part]
    if distributed and part > 0:
        barrier("folder")  # process 0 has set the folder up
    folder = RunFolder(out, meta, len(planned) + len(copied), resume or distributed and part > 0,
                       shared=parts > 1, keep=not (distributed and part > 0))
    if distributed and part == 0:
        barrier("folder")
    copy = _copies(reused, copied, len(planned), columns, folder, part, parts)
    work: dict[int, float] = {}  # per group, the device work of its chunks still to play
    for c in ours:
        if c.index not in folder.done:
            work[c.group] = (work.get(c.group, 0.0)
                             + groups[c.group].work * len(c.worlds) / len(groups[c.group].worlds))
    shares = share(work, processes if experiment.save_views == "none" else 1)
    # The run plays the lightest share itself: its XLA threads were started for every core
    # before it keeps to its block, so its chunks run slower than a helper's, whose threads
    # start on its block alone (measured the other way round: slower).
    mine = {c.index for c in ours if c.group in shares[-1]}
    skip = folder.done | {c.index for c in planned if c.index not in mine}
    per_chunk = {c.index: len(c.worlds) * groups[c.group].attempts for c in ours}
    bar, log = progress_bar(sum(per_chunk.values()), quiet,
                            sum(n for c, n in per_chunk.items() if c in folder.done))
    _log_sweep(experiment, reused, log)
    saver = ViewSaver(out, experiment.save_views, experiment.max_views, configs)
    lock = threading.Lock()  # the helpers' progress comes from threads of their own

    def progress(attempts: int) -> None:
        with lock:
            bar.update(attempts)

    clock.append(time.perf_counter())
    with bar:
        _play_shares(experiment, out, meta, groups, configs, batch, ours, shares, skip, folder,
                     columns, progress, log, bar.set_description_str, compile_first,
                     process=part if distributed else 0, saver=saver, host_work=copy)
        copy()  # where no device chunk was played here
    if distributed:
        barrier("played")  # every process's chunks are in the folder
        if part > 0:
            return RunResult(out, [], folder.chunks, folder.chunks, 0, float("nan"))
    clock.append(time.perf_counter())
    files = folder.finish(remove_parts=True if distributed else None)  # others are done
    if not files:
        return RunResult(out, [], len(folder.done), folder.chunks, 0, float("nan"))
    if (out / "timings.csv").is_file() and not resume:  # a resumed run's are partly old
        estimate.record_timings(groups, batch, experiment.save_views != "none",
                       pd.read_csv(out / "timings.csv"))
    clock.append(time.perf_counter())
    from graspjax.report import write_report
    from graspjax.report.files import load_attempts

    rows = folder.report_rows  # None where the rows were assembled earlier (a finished run)
    files += write_report(out, rows=rows)[0]
    clock.append(time.perf_counter())
    success = (rows[0] if rows is not None else load_attempts(out))["success"]
    lengths = [round(end - begin, 2) for begin, end in zip(clock[:-1], clock[1:], strict=True)]
    seconds = dict(zip(("start", "chunks", "rows", "report"), lengths, strict=True))
    if before is not None:
        seconds = {"before": round(before, 2), **seconds}
    return RunResult(out, files, folder.chunks, folder.chunks, len(success), float(success.mean()),
                     seconds)


def _log_sweep(experiment: Experiment, reused, log) -> None:
    """A sweep's grid and seeds in words, and what it reuses (`reuse.Reused`, or None)."""
    if experiment.sweep:
        log(f"{len(experiment.points)} grid points of {', '.join(experiment.keys)}; "
            + (f"every point has seed {experiment.seed} (paired)" if experiment.paired
               else f"point i has seed {experiment.seed} + i"))
    if reused:
        log(reused.summary(experiment.reuse))


def _copies(reused, points: list[int], first: int, columns: RunColumns, folder: RunFolder,
            part: int, parts: int):
    """A callable that keeps, once, the rows `reused` (`reuse.Reused`) gives grid point `points[i]`
    as chunk `first + i` (this process's share): the run calls it while the devices play."""
    pending = [(index, point) for index, point in enumerate(points, start=first)
               if index % parts == part and index not in folder.done]

    def copy() -> None:
        while pending:
            index, point = pending.pop(0)
            folder.add(index, *reused.rows(point, columns, index), None)
    return copy


def planned_groups(experiment: Experiment) -> tuple[list[estimate.PlannedGroup], list[str]]:
    """What `run` would play, group by group, and an estimate of its time (`batch.estimate`);
    and what it reuses, in words (none, or `reuse.Reused.summary`)."""
    reused = _reused(experiment)
    return (estimate.planned(_grouped(experiment, reused)[1], experiment.batch or default_batch(),
                             experiment.save_views != "none"),
            [reused.summary(experiment.reuse)] if reused else [])


def _reused(experiment: Experiment):
    """The finished run whose worlds `experiment` reuses (`reuse.load`: checked), or None."""
    if not experiment.reuse:
        return None
    from graspjax import reuse  # beside the report's files: read by a run that reuses one

    batch = experiment.batch or default_batch()
    return reuse.load(experiment.reuse, experiment, batch, run_meta(experiment, batch))


def _grouped(experiment: Experiment, reused) -> tuple[list[Config], list[Group]]:
    """The run's grid points and groups, less the worlds whose rows `reused` gives: one
    derivation for the run and its helpers, which must plan (and so number the chunks) alike."""
    configs = [c for _, c in experiment.points]
    return configs, plan(experiment.jobs, configs, experiment.seed, experiment.paired,
                         keep=reused.plays(configs) if reused else None)


def _play_shares(experiment: Experiment, out: Path, meta: dict, groups: list[Group],
                 configs: list[Config], batch: int, ours: list, shares: list[list[int]],
                 skip: set[int], folder: RunFolder, columns: RunColumns, progress, log, status,
                 compile_first: bool, process: int, saver, host_work=lambda: None) -> None:
    """The chunks of `ours` not in `skip` played into `folder`: the last of `shares` here, each
    other share by a helper process of its own (`runtime.players`), whose rows stream into the
    folder as they come; a failed helper stops the run. `host_work()` after each chunk kept."""
    helpers = []
    try:
        # Each process keeps to cores of its own only when every program loads from the
        # store: a process compiling on one core could not take the core another is done
        # with (measured cold on 2 cores: slower kept apart than in one process).
        work = {g for share in shares for g in share}
        warm = len(shares) > 1 and all(program(groups[g], batch, keep_views=False).stored()
                                       for g in work)
        for helper_process, groups_of_helper in enumerate(shares[:-1], start=1):
            todo = tuple(c.index for c in ours
                         if c.group in groups_of_helper and c.index not in folder.done)
            if todo:
                helpers.append(Helper(play_helper_share, experiment, str(out.absolute()), meta,
                                      helper_process, todo, progress,
                                      cores_of(helper_process, len(shares)) if warm else None))
        if helpers:
            log(f"playing the groups in {len(helpers) + 1} processes side by side")
        with kept_to(cores_of(0, len(shares)) if helpers and warm else None):
            _play(groups, configs, batch, skip, folder, columns, progress, log,
                  process=process, saver=saver, keep_views=experiment.save_views != "none",
                  overlap=not compile_first, status=status,
                  after_chunk=lambda: [host_work(), folder.catch_up(), *(h.check() for h in helpers)])
        while any(helper.running() for helper in helpers):  # stream the helpers' rows
            folder.catch_up()
            for helper in helpers:
                helper.check()
            time.sleep(0.5)
        folder.catch_up()
        for helper in helpers:
            helper.wait()
    finally:
        for helper in helpers:
            helper.stop()


def _play(groups: list[Group], configs: list[Config], batch: int, skip: set[int],
          folder: RunFolder, columns: RunColumns, progress, log, process: int = 0,
          saver=None, keep_views: bool = False, after_chunk=lambda: None,
          overlap: bool = True, status=lambda text: None) -> None:
    """Play every chunk not in `skip` into `folder`: its rows, layouts and timings, and its
    views (with `saver`, when kept); `after_chunk()` once each is kept (the run: a helper that
    failed stops it). `process`: which of the run's processes plays them; `overlap`: chunks
    start while other programs still compile; `status(text)`: what compiles (`run_chunks`)."""
    for result in run_chunks(groups, configs, batch, skip, keep_views=keep_views,
                             progress=progress, log=log, process=process, overlap=overlap,
                             status=status):
        frame = attempt_rows(result, columns)
        if result.views is not None:  # before the chunk is marked done: a kill between the
            saver.save(result.chunk, frame, result.views)  # two replays the chunk and its views
        folder.add(result.chunk.index, frame, round_rows(result, columns), result.timings)
        if process == 0:
            import_in_background("graspjax.report")
        after_chunk()


def play_helper_share(job: Assignment, progress) -> None:
    """A helper process's part of a run (`runtime.players`): the same plan as the run's, its
    chunks into the run's folder, and `progress(attempts)` as each call finishes."""
    experiment = job.experiment
    reused = _reused(experiment)
    configs, groups = _grouped(experiment, reused)
    planned = chunks(groups, job.meta["batch"])
    columns = RunColumns(job.meta["run_id"], configs, experiment.keys, experiment.base)
    total = len(planned) + (len(reused.copied_points(configs)) if reused else 0)
    folder = RunFolder(job.out, job.meta, total, resume=True, shared=True, keep=False)
    skip = {c.index for c in planned} - set(job.chunks)
    _play(groups, configs, job.meta["batch"], skip, folder, columns, progress, lambda m: None,
          process=job.process)


def plane_study(jobs: list[Job], base: Config, points: list[tuple[dict[str, str], Config]],
                keys: list[str], seed: int, batch: int | None, preset: str, out: str | Path,
                overwrite: bool = False, quiet: bool = False,
                config_file: dict | None = None) -> tuple[pd.DataFrame, dict, Path]:
    """`graspjax planes`: settle the worlds, take each first view and judge the re-alignment's
    plane for every grid point (traced `align.*` values) into `out`: planes.csv.gz,
    planes_summary.csv, planes.png, config.json (with `config_file`, what --config gave). Returns the
    summary, the timings and the folder."""
    from graspjax import planes
    from graspjax.report import plane_outputs

    out = check_output_folder(out, overwrite=overwrite)
    with writing(out):  # a run (or another study) writing the folder stops it here
        if overwrite:  # nothing of what the folder held may stay beside the study
            remove_own_files(out)
        groups = plan(jobs, [base], seed)
        batch = batch or default_batch()
        bar, _ = progress_bar(sum(len(g.worlds) for g in groups), quiet, unit="world")
        with bar:
            rows, timings = planes.study(groups, [c for _, c in points], batch, bar.update)
        grid = {k: [p[0][k] for p in points] for k in keys}
        for k, values in grid.items():
            rows.insert(1 + list(grid).index(k), k, [values[i] for i in rows.point])
        meta = {"seed": seed, "preset": preset, "jobs": [dataclasses.asdict(j) for j in jobs],
                "overrides": differences(base, Config()), "config_file": config_file,
                "grid": grid, "batch": batch,
                "config": run_settings(base), "timings": timings, **provenance()}
        write_atomic(out / "planes.csv.gz",
                     gzip.compress(rows.to_csv(index=False).encode(), mtime=0))
        outputs = plane_outputs(rows, meta)
        for name, data in outputs.items():
            write_atomic(out / name, data)
        write_atomic(out / "config.json", json.dumps(meta, indent=1, default=jsonable).encode())
    return planes.summarize(rows, grid), timings, out


@dataclasses.dataclass(frozen=True)
class DetectOutputs:
    """Where a detection run writes (each None: not written). Checked writable by the caller."""

    json: str | None = None  # the record (one image) or the list of records
    figure: str | None = None  # the debug figure of the one image
    figures: str | None = None  # a folder: one debug figure per image
    csv: str | None = None  # the results table
    folder: str | None = None  # a folder: results.csv and results.json


def detect_images(inputs, outputs: DetectOutputs, batch: int | None = None, quiet: bool = False
                  ) -> list[dict]:
    """`graspjax detect`: every image of `inputs` (`imagefiles.inputs.prepare`) through the
    detector, `batch` images per call (None: `batches.default_image_batch`); its records (JSON values),
    with the files of `outputs` written atomically once everything has run (figures as each
    image is done)."""
    from graspjax.figures.views import real_image_figure
    from graspjax.imagefiles import records as rec
    from graspjax.imagefiles.batches import detect_files

    many = len(inputs.paths) > 1
    names = figure_names(inputs.paths)
    if outputs.figures:
        Path(outputs.figures).mkdir(exist_ok=True)
    records, first_figure = {}, None
    bar, log = progress_bar(len(inputs.paths), quiet, unit="image", show_bar=many)
    with bar:
        for found in detect_files(inputs, batch, bar.update, log):
            records[found.index] = rec.record(found)
            if outputs.figure or outputs.figures:
                png = real_image_figure(found.depth, found.workspace, found.camera, found.result,
                                        found.inputs.config, found.inputs.image,
                                        title=str(found.path))
                if outputs.figures:
                    write_atomic(Path(outputs.figures) / names[found.index], png)
                else:
                    first_figure = png
    records = [records[i] for i in sorted(records)]  # the inputs' order (`detect_files`: by part)
    if outputs.json:
        write_atomic(outputs.json, rec.json_bytes(records, many))
    if outputs.figure:
        write_atomic(outputs.figure, first_figure)
    if outputs.csv:
        write_atomic(outputs.csv, rec.csv_bytes(records))
    if outputs.folder:
        Path(outputs.folder).mkdir(exist_ok=True)
        write_atomic(Path(outputs.folder) / "results.csv", rec.csv_bytes(records))
        write_atomic(Path(outputs.folder) / "results.json", rec.json_bytes(records, True))
    return records


def figure_names(paths: list[Path] | tuple[Path, ...]) -> list[str]:
    """Distinct PNG names for the images, each a bare file name (no folder, no root), so that it
    stays in the figures' folder: their stems, prefixed by as many parent folders as it takes to
    tell them apart (joined by '_'), else numbered."""
    resolved = [p.resolve().with_suffix("") for p in paths]
    parts = [q.relative_to(q.anchor).parts for q in resolved]  # the root is no folder's name
    for depth in range(1, max(len(q) for q in parts) + 1):
        names = ["_".join(q[-depth:]) for q in parts]
        if len(set(names)) == len(names):
            return [n + ".png" for n in names]
    return [f"{i:05d}_{p.stem}.png" for i, p in enumerate(paths)]
