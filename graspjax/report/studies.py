"""One study's parts drawn as one figure: the folders of a paired sweep of the same key run
cell by cell at the trials each cell needs (`experiments/studies.sh`'s `TAG`ged folders),
a panel per setup and object set, each with its own number of objects."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from graspjax.figures import png
from graspjax.figures.report import sweep_figure, swept_points
from graspjax.report.files import read_meta
from graspjax.report.tables import object_letters, object_outcomes, varying_config


def study_points(parts: list[tuple[pd.DataFrame, dict]]) -> tuple[pd.DataFrame, str, str]:
    """The paired points (`swept_points`) of each part of one study, `parts`: (attempt rows,
    config.json) per folder, every one a sweep of the same single key under the same preset
    and settings. Each part's setups are its panels, named by the setup and, where the part
    played only some objects, their letters ("1 g-l", "1 a, b"). Returns the points (their `setup`
    column the panel names), the swept key and the figure's title. A part that sweeps
    another key or runs under other settings than the first is refused (ValueError)."""
    frames, key, first = [], None, None
    for frame, meta in parts:
        keys = varying_config(frame)
        settings = (meta.get("preset"), meta.get("overrides", {}), meta.get("paired"))
        if len(keys) != 1 or (key is not None and keys[0] != key):
            raise ValueError(f"each part must sweep the one key {key or 'of the first'}, "
                             f"not {', '.join(keys) or 'none'}")
        if first is not None and settings != first:
            raise ValueError(f"the parts run under other settings: {settings} against {first}")
        key, first = keys[0], settings
        objects = object_outcomes(frame)
        letters = set(objects["object"].unique())
        some = "" if len(letters) == 12 else f" {object_letters(letters)}"
        per = swept_points(objects, key)
        frames.append(per.assign(setup=per["setup"].map(lambda s, some=some: f"{s}{some}")))
    if key is None:
        raise ValueError("no parts given")
    preset, overrides, paired = first
    changed = ", ".join(f"{k}={v}" for k, v in overrides.items())
    trials = sorted({job.get("trials") for _, meta in parts for job in meta.get("jobs", [])}
                    - {None})
    title = (f"{key[len('cfg.'):]}, {preset} preset" + (f" ({changed})" if changed else "")
             + f", each panel at its own trials ({' / '.join(f'{n:,}' for n in trials)} per cell)"
             + (", paired" if paired else ""))
    points = pd.concat(frames, ignore_index=True).sort_values(["setup", key], kind="stable")
    return points.reset_index(drop=True), key, title


def study_figure(folders: list[str | Path]) -> bytes:
    """`study_points` of these run folders (their rows and config.json) as one PNG
    (`sweep_figure`: rates, first view and rescued, and the paired differences per panel)."""
    from graspjax.report import load_attempts

    per, key, title = study_points([(load_attempts(f), read_meta(f)) for f in folders])
    return png(sweep_figure(per, key, title), laid_out=True)
