"""Detection on real depth images: `detect_real_image` over chunks of files.

The images go through one compiled call per chunk of `batch` images (the last chunk padded
to the same size; a chunk of one is not vmapped: `detect_single`), each with its own
intrinsics; images at other resolutions than the first's (`Inputs.parts`) in chunks of their
own. Every image's result comes back with the views its steps worked on, so a figure never
recomputes them.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import jax
import numpy as np

from graspjax.camera import Camera
from graspjax.config import for_device
from graspjax.imagefiles.inputs import Inputs
from graspjax.perception.real_image import RealImageDetection, detect_real_image

#: `detect_real_image` over a batch: depth (B, H, W), workspace (H, W), a `Camera` whose fx, fy,
#: cx, cy are (B,) arrays (`stack_cameras`), `Config`, `RealImageConfig`. One compile per batch
#: size, image size and configuration.
detect_batch = jax.jit(jax.vmap(detect_real_image, in_axes=(0, None, 0, None, None)))
#: The same with a workspace (B, H, W) of each image's own (`graspjax detect --bin`).
detect_batch_own_workspaces = jax.jit(jax.vmap(detect_real_image, in_axes=(0, 0, 0, None, None)))
#: One image per call, not batched: under `vmap` a `lax.cond` runs both of its branches (the
#: contour search, a given-up target's surface), one image runs only the one it takes.
detect_single = jax.jit(detect_real_image)


def default_image_batch() -> int:
    """`graspjax detect`'s images per call: 16 on a GPU or TPU, where a batch fills the device;
    1 on a CPU, where an image of a batch takes longer than one alone (a batch runs both
    branches of every `lax.cond`; results/benchmarks/detect_single_calls)."""
    return 1 if jax.default_backend() == "cpu" else 16


def stack_cameras(cameras: Sequence[Camera]) -> Camera:
    """One `Camera` (fx, fy, cx, cy of shape (B,)) from B cameras of one size, for `detect_batch`."""
    c0 = cameras[0]
    return Camera(c0.width, c0.height, *(np.array([getattr(c, f) for c in cameras], np.float32)
                                         for f in ("fx", "fy", "cx", "cy")))


@dataclasses.dataclass(frozen=True)
class Detection:
    """One image's detection, on the host."""

    index: int  # position among the inputs
    path: Path
    inputs: Inputs  # the images detected at its resolution (`Inputs.parts`): its settings
    depth: np.ndarray  # (H, W) metric depth at full resolution
    workspace: np.ndarray  # (H, W) bool: where the search looked (`Inputs.workspace_of`)
    camera: Camera  # its full-resolution intrinsics
    source: str  # where the intrinsics came from
    result: RealImageDetection  # numpy, single image (with its views)
    load_s: float  # reading the file
    compute_s: float  # its share of the compiled call


def detect_files(inputs: Inputs, batch: int | None = None,
                 progress: Callable[[int], None] = lambda n: None,
                 log: Callable[[str], None] = lambda m: None) -> Iterator[Detection]:
    """Every image's `Detection`, `batch` images per compiled call (None:
    `default_image_batch`; 1: `detect_single`): in order, part by part (`Inputs.parts`: the
    images at the first image's resolution, then those at each other).

    progress(n): n more images done; log: a line about each part's first call's compile.
    """
    parts = inputs.parts()
    for indices, part in parts:
        yield from _detect_part(part, indices, batch, progress,
                                log if len(parts) == 1 else lambda m, p=part: log(
                                    f"{m} (detection block {p.image.downsample}, input "
                                    f"block {p.reduction})"))


def _detect_part(inputs: Inputs, indices: tuple[int, ...], batch: int | None,
                 progress: Callable[[int], None], log: Callable[[str], None]
                 ) -> Iterator[Detection]:
    """`detect_files` of the images of one resolution, at positions `indices` of the run."""
    batch = max(1, min(batch or default_image_batch(), len(inputs.paths)))
    own = inputs.bins is not None
    settings = (for_device(inputs.config, jax.default_backend(), images=True), inputs.image)  # this device's

    def detect(depths, workspace, cameras):
        """depths (B, H, W), the workspace (H, W) or each image's (B, H, W), B `Camera`s: the
        results as NumPy (B, ...)."""
        if batch == 1:
            result = detect_single(depths[0], workspace[0] if own else workspace, cameras[0],
                                   *settings)
            return jax.tree.map(lambda x: np.asarray(x)[None], result)  # on the host
        call = detect_batch_own_workspaces if own else detect_batch
        return jax.tree.map(np.asarray, call(depths, workspace, stack_cameras(cameras), *settings))

    compiled = False
    for start in range(0, len(inputs.paths), batch):
        chunk = inputs.paths[start:start + batch]
        depths, workspaces, cameras, sources, loads = [], [], [], [], []
        for i, path in enumerate(chunk):
            t0 = time.perf_counter()
            depth, camera, source = inputs.read(path)
            depths.append(depth)
            workspaces.append(inputs.workspace_of(start + i))
            cameras.append(camera)
            sources.append(source)
            loads.append(time.perf_counter() - t0)
        pad = batch - len(chunk)  # one compiled size: repeat the last image
        stacked = np.stack(depths + [depths[-1]] * pad)
        workspace = np.stack(workspaces + [workspaces[-1]] * pad) if own else inputs.workspace
        padded_cameras = cameras + [cameras[-1]] * pad
        if not compiled:
            t0 = time.perf_counter()
            detect(stacked, workspace, padded_cameras)
            log(f"compiled and ran the first {batch} image(s) in {time.perf_counter() - t0:.1f} s")
            compiled = True
        t0 = time.perf_counter()
        result = detect(stacked, workspace, padded_cameras)
        per_image = (time.perf_counter() - t0) / batch
        for i, path in enumerate(chunk):
            yield Detection(index=indices[start + i], path=path, inputs=inputs, depth=depths[i],
                            workspace=workspaces[i], camera=cameras[i],
                            source=sources[i], result=jax.tree.map(lambda x, i=i: x[i], result),
                            load_s=loads[i], compute_s=per_image)
        progress(len(chunk))
