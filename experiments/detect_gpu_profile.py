"""Where `graspjax detect`'s batch spends device time: kernels summed by the source line they
come from, and how the batch scales.

    python3 experiments/detect_gpu_profile.py OUT_DIR [BATCH] [--trace-only]

On a GPU, XLA runs sequences of kernels as command buffers (CUDA graphs) whose kernels the
trace does not name: add `--xla_gpu_enable_command_buffer=` to XLA_FLAGS for the attribution.

1. Times `detect_batch` (top 5) at BATCH and 4 x BATCH, and with one target
   (`image.max_targets=1`) at both: a device that is busy scales with the
   batch, one that waits on launches and loop conditions does not.
2. Traces one batch with `jax.profiler` and sums the device time of every
   kernel by the source line of the operation it was fused from (from the
   compiled program's HLO metadata); prints the 40 largest and the share of
   the wall time the device was busy. Writes the trace and the HLO to
   OUT_DIR. Images: `synthetic.random_real_scene` at 640 x 480.
"""

import collections
import gzip
import json
import pathlib
import re
import sys
import time

import jax
import jax.numpy as jnp
import numpy as np

from graspjax.bench import detect_workload, median_seconds
from graspjax.config import Config, RealImageConfig
from graspjax.imagefiles.batches import detect_batch, stack_cameras

W, H = 640, 480
CAMERA, WORKSPACE, SCENES = detect_workload(W, H)  # graspjax bench detect's images
_META = re.compile(r"^\s*(?:ROOT )?%?([\w.\-]+) = .*?metadata=\{([^}]*)\}")


def _tables(hlo: str) -> tuple[dict, dict, dict, dict]:
    """The HLO text's FileNames, FunctionNames, FileLocations and StackFrames tables."""
    tables, current = {}, None
    for line in hlo.splitlines():
        if line in ("FileNames", "FunctionNames", "FileLocations", "StackFrames"):
            current = tables.setdefault(line, {})
        elif current is not None and re.match(r"^\d+ ", line):
            key, value = line.split(" ", 1)
            current[int(key)] = value.strip('"')
        else:
            current = None
    return (tables.get("FileNames", {}), tables.get("FunctionNames", {}),
            tables.get("FileLocations", {}), tables.get("StackFrames", {}))


def _source_lines(hlo: str) -> dict[str, str]:
    """HLO instruction name -> 'file:line function (op)' of the innermost source frame it came
    from, from the optimized HLO text's metadata."""
    files, functions, locations, frames = _tables(hlo)

    def frame_text(frame_id: int) -> str:
        frame = frames.get(frame_id, "")
        location = re.search(r"file_location_id=(\d+)", frame)
        fields = locations.get(int(location.group(1)), "") if location else ""
        file = re.search(r"file_name_id=(\d+)", fields)
        function = re.search(r"function_name_id=(\d+)", fields)
        number = re.search(r"line=(\d+)", fields)
        if not (file and function and number):
            return "?"
        return (f"{pathlib.Path(files.get(int(file.group(1)), '?')).name}:{number.group(1)} "
                f"{functions.get(int(function.group(1)), '?')}")

    found = {}
    for line in hlo.splitlines():
        match = _META.match(line)
        if not match:
            continue
        meta = match.group(2)
        frame = re.search(r"stack_frame_id=(\d+)", meta)
        op = re.search(r'op_name="([^"]*)"', meta)
        last = op.group(1).split("/")[-1] if op else "?"
        found[match.group(1)] = f"{frame_text(int(frame.group(1))) if frame else '?'} ({last})"
    return found


def print_profile(run, args, hlo: str, trace_dir: pathlib.Path, what: str, top: int = 40) -> None:
    """Trace one call of `run(*args)` (compiled and warm) with `jax.profiler` and print its device
    time by source line, by innermost function and by source file (`hlo`: the compiled text)."""
    sources = _source_lines(hlo)
    t0 = time.perf_counter()
    with jax.profiler.trace(str(trace_dir), create_perfetto_trace=True):
        jax.block_until_ready(run(*args))
    wall = time.perf_counter() - t0
    trace_file = next(trace_dir.rglob("perfetto_trace.json.gz"))
    events = json.loads(gzip.decompress(trace_file.read_bytes()))
    events = events["traceEvents"] if isinstance(events, dict) else events
    threads = {(e.get("pid"), e.get("tid")): e.get("args", {}).get("name", "")
               for e in events if e.get("ph") == "M" and e.get("name") == "thread_name"}
    on_gpu = any("stream" in name.lower() for name in threads.values())
    by_source = collections.Counter()
    calls = collections.Counter()
    busy = 0.0
    for e in events:
        if e.get("ph") != "X" or "dur" not in e:
            continue
        thread = threads.get((e.get("pid"), e.get("tid")), "")
        info = e.get("args", {})
        if "stream" not in thread.lower() and (on_gpu or "hlo_op" not in info):
            continue  # on the CPU: the XLA operations themselves
        op = info.get("hlo_op") or e.get("name", "?")
        key = sources.get(op, op)
        by_source[key] += e["dur"]
        calls[key] += 1
        busy += e["dur"]
    print(f"\n{what} traced: {1e3 * wall:.1f} ms wall (traced), "
          f"device kernels {busy / 1e3:.1f} ms in all")
    print(f"{'ms':>8} {'share':>6} {'calls':>7}  source")
    for key, micros in by_source.most_common(top):
        print(f"{micros / 1e3:8.2f} {micros / max(busy, 1):6.1%} {calls[key]:7d}  {key}")
    by_function, by_file = collections.Counter(), collections.Counter()
    for key, micros in by_source.items():
        match = re.match(r"^(\S+?):\d+ (\S+)", key)
        by_function[f"{match.group(1)} {match.group(2)}" if match else key] += micros
        by_file[match.group(1) if match else "?"] += micros
    for title, counter, rows in (("function (innermost)", by_function, 25),
                                 ("file", by_file, 15)):
        print(f"\n{'ms':>8} {'share':>6}  {title}")
        for key, micros in counter.most_common(rows):
            print(f"{micros / 1e3:8.2f} {micros / max(busy, 1):6.1%}  {key}")

def main() -> None:
    out = pathlib.Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    batch = int(sys.argv[2]) if len(sys.argv) > 2 else 1024
    scaling = "--trace-only" not in sys.argv
    config = Config()
    print(f"{jax.devices()[0].device_kind}, jax {jax.__version__}", flush=True)

    def program(size, image):
        depth = jnp.asarray(SCENES[np.arange(size) % 64])
        cameras = stack_cameras([CAMERA] * size)
        run = jax.jit(lambda d, c: detect_batch(d, WORKSPACE, c, config, image))
        return run, depth, cameras

    for targets in (8, 1) if scaling else ():
        for size in (batch, 4 * batch):
            run, depth, cameras = program(size, RealImageConfig(top_k=5, max_targets=targets))
            jax.block_until_ready(run(depth, cameras))  # compile
            seconds = median_seconds(lambda run=run, depth=depth, cameras=cameras:
                                     run(depth, cameras), 5)
            print(f"max_targets {targets}, batch {size:>5}: {1e3 * seconds:7.1f} ms, "
                  f"{size / seconds:8,.0f} images/s", flush=True)

    run, depth, cameras = program(batch, RealImageConfig(top_k=5))
    hlo = run.lower(depth, cameras).compile().as_text()
    (out / "detect_hlo.txt.gz").write_bytes(gzip.compress(hlo.encode()))
    jax.block_until_ready(run(depth, cameras))
    print_profile(run, (depth, cameras), hlo, out / "trace", f"one batch of {batch}")


if __name__ == "__main__":
    main()
