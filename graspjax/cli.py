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

    if args.batch < 1 or args.repeats < 1:
        raise UsageError("--batch and --repeats must be >= 1")
    config = override(Config(), args.set or [])
    result = perception_benchmark(batch=args.batch, width=args.width, height=args.height,
                                  repeats=args.repeats, config=config,
                                  progress=lambda m: print(m, file=sys.stderr))
    if args.out:
        from graspjax.io import write_atomic

        write_atomic(args.out, (json.dumps(_jsonable(result), indent=2) + "\n").encode())
    print(format_perception(result))
    return 0


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

    p = sub.add_parser("bench", help="benchmarks (print numbers; compile time apart)")
    p.add_argument("what", choices=["perception"], help="what to measure")
    p.add_argument("--batch", type=int, default=4096, help="images per batched call")
    p.add_argument("--width", type=int, default=160)
    p.add_argument("--height", type=int, default=120)
    p.add_argument("--repeats", type=int, default=10, help="timed calls (median is reported)")
    p.add_argument("--out", help="write the full record to this JSON file")
    p.add_argument("--set", action="append", metavar="KEY=VALUE")
    p.set_defaults(func=cmd_bench)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
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
