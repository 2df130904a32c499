"""A figure's title from its run's `config.json`: the preset and the settings changed from
it, the setups, the objects where not all twelve, the trials, the pairing."""

from __future__ import annotations

from graspjax.report.tables import objects_named


def preset_description(meta: dict) -> str:
    """"paper preset (changed=value)": a run's preset and the settings changed from it
    (`config.json`)."""
    changed = ", ".join(f"{k}={v}" for k, v in meta.get("overrides", {}).items())
    return f"{meta.get('preset', 'unknown')} preset" + (f" ({changed})" if changed else "")


def trials_description(metas: list[dict]) -> str:
    """"600/1500 trials per cell": the trials of the runs' jobs ("" where none says)."""
    trials = sorted({job.get("trials") for m in metas for job in m.get("jobs", [])} - {None})
    return f"{'/'.join(map(str, trials))} trials per cell" if trials else ""


def pairing(meta: dict) -> str:
    """", paired" or ", unpaired" as the run's `config.json` says, "" where it does not."""
    return (", paired" if meta["paired"] else ", unpaired") if "paired" in meta else ""


def run_description(meta: dict, setups) -> str:
    """"paper preset (changed=value), Setup 1, objects g-l, 600 trials per cell": the preset,
    the settings changed from it, the setups, the objects of all its jobs where they are not
    the twelve, and the trials of a run's `config.json`."""
    objects = objects_named(o for job in meta.get("jobs", []) for o in job.get("objects", []))
    trials = trials_description([meta])
    return (preset_description(meta)
            + f", Setup{'s' if len(setups) > 1 else ''} {', '.join(map(str, setups))}"
            + (f", objects {objects}" if objects else "") + (f", {trials}" if trials else ""))


def sweep_title(key: str, meta: dict | None, setups) -> str:
    """A study figure's title: what was swept, under which preset and the settings changed from
    it, in which setups, how many trials, paired or not (from the run's `config.json`, where it
    has one)."""
    meta = meta or {}
    name = key[len("cfg."):] if key.startswith("cfg.") else key
    return f"{name}, {run_description(meta, setups)}{pairing(meta)}"


def planes_title(meta: dict) -> str:
    """A plane study figure's title: the grid's keys, the preset, the setups and trials, and
    the settings changed from the preset (config.json)."""
    setups = sorted({s for job in meta.get("jobs", []) for s in job.get("setups", [])})
    return (f"The re-alignment's plane over {' x '.join(meta.get('grid', {}))}, "
            f"{run_description(meta, setups)}; views with no grasp in the first view")
