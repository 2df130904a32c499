"""Debug views of simulated attempts: what the camera saw and what the method made of it.

`graspjax run --save-views failed|all` keeps, for the chosen attempts (at
most `--max-views`), one compressed `views/<attempt>.npz` each: the depth
image of the overview and of every view the procedure took, the pixels where the
method took z_min and the credited object's pixels (ground truth),
the camera poses, the detection of each view (its surface cluster, contour,
straight edges and every T-beam placement) and its alignment planes, about
0.2 MB per attempt. `graspjax report DIR --debug N` draws the first N as the
paper's Figs. 2-5 and 8 (`figures.views.attempt_figure`).
"""

from __future__ import annotations

import dataclasses
import io
from pathlib import Path
from typing import TYPE_CHECKING

import jax
import numpy as np
import pandas as pd

from graspjax.config import Config
from graspjax.disk import write_atomic
from graspjax.perception import Alignment, Grasp
from graspjax.perception.contour import Contour, Edges
from graspjax.perception.grasp import surface_contour
from graspjax.perception.placements import TBeams
from graspjax.tree import named_fields

if TYPE_CHECKING:
    from graspjax.batch.program import ChunkViews

_NESTED = {"grasp": Grasp, "alignment": Alignment, "grasp.edges": Edges,
           "grasp.candidates": TBeams, "contour": Contour}


def _arrays(parts: dict) -> dict[str, np.ndarray]:
    """Dataclasses of arrays by name -> {'name.field.subfield': array}, for one `.npz`."""
    return {f"{name}.{key}": np.asarray(value) for name, part in parts.items()
            for key, value in named_fields(part).items()}


def _build(prefix: str, arrays: dict) -> object:
    cls = _NESTED[prefix]
    values = {}
    for f in dataclasses.fields(cls):
        name = f"{prefix}.{f.name}"
        values[f.name] = _build(name, arrays) if name in _NESTED else arrays[name]
    return cls(**values)


def attempt_name(row) -> str:
    """File stem of one attempt: point, setup, trial (the round in Setups 2, 3), attempt and
    object."""
    return (f"p{int(row.point):03d}_s{int(row.setup)}_r{int(row.trial):05d}"
            f"_a{int(row.attempt)}_{row.object}")


def point_of(stem: str) -> int:
    """The grid point of an attempt, from its file stem (`attempt_name`)."""
    return int(stem.split("_")[0][1:])


class ViewSaver:
    """Writes the views of the chosen attempts of each finished chunk (module docstring)."""

    def __init__(self, folder: Path, mode: str, cap: int, points: list[Config]):
        self.folder, self.mode, self.cap, self.points = Path(folder) / "views", mode, cap, points
        self.saved = len(list(self.folder.glob("*.npz"))) if self.folder.is_dir() else 0
        self._contour = jax.jit(jax.vmap(surface_contour, in_axes=(0, None, 0)))

    def save(self, chunk, frame: pd.DataFrame, views: ChunkViews) -> None:
        """Keep the views of `frame`'s chosen attempts (left on the devices until chosen)."""
        if self.mode == "none" or self.saved >= self.cap:
            return
        chosen = frame[frame["attempt"] >= 0]
        if self.mode == "failed":
            chosen = chosen[chosen["success"] == 0]
        chosen = chosen.head(self.cap - self.saved)
        index = {(w.point, w.setup, w.trial, "".join(w.objects)): i
                 for i, w in enumerate(chunk.worlds)}
        self.folder.mkdir(parents=True, exist_ok=True)
        for row in chosen.itertuples():
            w = index[(row.point, row.setup, row.trial, row.objects)]
            view = views.get(row.attempt, w)
            config = self.points[row.point]
            camera = config.camera.camera()
            seed, cluster, z_s, contour = self._contour(view.depth[1:], config.detect,
                                                        view.seed_mask[1:])
            arrays = {"depth": view.depth, "target_mask": view.target_mask,
                      "seed_mask": view.seed_mask,
                      "rotation": view.rotation, "position": view.position, "looked": view.looked,
                      "seed": np.asarray(seed), "cluster": np.asarray(cluster),
                      "surface_depth": np.asarray(z_s),
                      **_arrays({"grasp": view.grasp, "alignment": view.alignment,
                                 "contour": contour, "state": view.state}),
                      "camera": np.array([camera.fx, camera.fy, camera.cx, camera.cy]),
                      "label": np.array([f"Setup {row.setup}, trial {row.trial}, attempt "
                                         f"{row.attempt}, object {row.object}: {row.reason}"])}
            path = self.folder / f"{attempt_name(row)}.npz"
            self.saved += not path.exists()  # a resumed chunk's views are written again
            buffer = io.BytesIO()
            np.savez_compressed(buffer, **arrays)
            write_atomic(path, buffer.getvalue())  # a kill leaves the whole file or none


@dataclasses.dataclass(frozen=True)
class SavedAttempt:
    """One attempt's views read back from disk (numpy)."""

    label: str
    depth: np.ndarray  # (1 + V, H, W)
    target_mask: np.ndarray  # (1 + V, H, W) bool the credited object (ground truth)
    seed_mask: np.ndarray  # (1 + V, H, W) bool where the method took z_min
    looked: np.ndarray  # (1 + V,) bool
    camera: np.ndarray  # (4,) fx, fy, cx, cy
    seed: np.ndarray  # (V, 2) z_min pixel of each view
    cluster: np.ndarray  # (V, H, W) bool surface cluster of each view
    surface_depth: np.ndarray  # (V,)
    contour: Contour  # leading axis V
    grasp: Grasp  # leading axis V
    alignment: Alignment  # leading axis V

    def view(self, v: int) -> tuple[Grasp, Alignment, Contour]:
        """Detection, alignment and contour of view v (0 = the centred view)."""
        return jax.tree.map(lambda x: x[v], (self.grasp, self.alignment, self.contour))


def load(path: str | Path) -> SavedAttempt:
    """Read one `views/*.npz`; a ValueError naming the file where it is cut or not one."""
    import zipfile
    import zlib

    try:
        with np.load(path) as data:
            arrays = dict(data)
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        raise ValueError(f"{path} cannot be read as saved views ({exc}): remove it, or run "
                         "again to save it") from None
    try:
        return _attempt(arrays)
    except KeyError as exc:
        raise ValueError(f"{path} is no saved attempt (it lacks {exc})") from None


def _attempt(arrays: dict[str, np.ndarray]) -> SavedAttempt:
    return SavedAttempt(label=str(arrays["label"][0]), depth=arrays["depth"],
                        target_mask=arrays["target_mask"],
                        seed_mask=arrays["seed_mask"],
                        looked=arrays["looked"],
                        camera=arrays["camera"], seed=arrays["seed"], cluster=arrays["cluster"],
                        surface_depth=arrays["surface_depth"],
                        contour=_build("contour", arrays), grasp=_build("grasp", arrays),
                        alignment=_build("alignment", arrays))
