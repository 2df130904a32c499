"""One study's parts drawn as one figure: the folders of a paired sweep of the same key run
cell by cell at the trials each cell needs (`experiments/studies.sh`'s `TAG`ged folders),
a panel per setup and object set, each with its own number of objects."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from graspjax.figures import png
from graspjax.figures.report import sweep_figure, swept_points
from graspjax.figures.titles import pairing, preset_description, trials_description
from graspjax.report.files import load_attempts, read_meta
from graspjax.report.tables import object_outcomes, objects_named, varying_config


def study_points(parts: list[tuple[pd.DataFrame, dict]]) -> tuple[pd.DataFrame, str, str]:
    """The paired points (`swept_points`) of each part of one study.

    parts: (attempt rows, config.json) per folder, each a sweep of the same single key under
    the same settings (preset, overrides, pairing). Each part's setups are its panels, named
    by the setup and, where the part played only some objects in it, their letters ("1 g-l",
    "2 a-f"). Returns the points (their `setup` column the panel names, sorted), the swept key
    and the figure's title. No parts, a part that sweeps another key or runs under other
    settings than the first, or two parts with the same panel are refused (ValueError)."""
    if not parts:
        raise ValueError("no parts given")
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
        named = {s: objects_named(o) for s, o in objects.groupby("setup")["object"]}
        per = swept_points(objects, key)
        frames.append(per.assign(setup=[f"{s} {named[s]}".strip() for s in per["setup"]]))
    points = pd.concat(frames, ignore_index=True)
    twice = sorted(points.loc[points.duplicated(["setup", key]), "setup"].unique())
    if twice:
        raise ValueError(f"two parts play the same panel: Setup {', '.join(twice)}")
    metas = [meta for _, meta in parts]
    trials = trials_description(metas)
    if trials:
        trials = f", each panel at its own trials ({trials})" if len(parts) > 1 else f", {trials}"
    title = f"{key[len('cfg.'):]}, {preset_description(metas[0])}{trials}{pairing(metas[0])}"
    points = points.sort_values(["setup", key], kind="stable").reset_index(drop=True)
    return points, key, title


def study_figure(folders: list[str | Path]) -> bytes:
    """`study_points` of these run folders (their rows and config.json) as one PNG
    (`sweep_figure`: rates, first view and rescued, and the paired differences per panel)."""
    per, key, title = study_points([(load_attempts(f), read_meta(f)) for f in folders])
    return png(sweep_figure(per, key, title), laid_out=True)
