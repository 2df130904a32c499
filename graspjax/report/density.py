"""Setup 3's settled-layout bounds (`docs/simulation.md`, stated from the paper's words before
they were measured), judged on a frame of settled rounds alone: one row per round with the
`schema.LAYOUT_COLUMNS` and `placed_spread_m` (the largest distance between two objects'
origins as the layout placed them, before it settled)."""

from __future__ import annotations

import dataclasses
import io
import math
from collections.abc import Callable

import numpy as np
import pandas as pd

_Z99 = 2.326348  # one-sided 1 %: a sample is consistent with a bound unless it is this far off


@dataclasses.dataclass(frozen=True)
class Bound:
    """One stated bound: a mean over rounds, or a share of rounds, at least or at most `limit`."""

    name: str  # short name
    paper: str  # the paper's words it reads
    what: str  # the statistic
    per_round: Callable[[pd.DataFrame], pd.Series]  # (R,) a value (mean) or a flag (share) per round
    share: bool  # the statistic is the share of rounds flagged (else the mean of the values)
    at_least: bool  # the statistic must be >= limit (else <= limit)
    limit: float


SETUP3_BOUNDS = (
    Bound("near", "positioned close to each other within minimal distance",
          "objects within 2 mm of another's outline, mean over rounds",
          lambda f: f["near_fraction"], False, True, 0.80),
    Bound("isolated", "positioned close to each other within minimal distance",
          "rounds in which no object lies within 2 mm of another",
          lambda f: f["near_fraction"] <= 0, True, False, 0.01),
    Bound("gap", "positioned close to each other within minimal distance",
          "median nearest face-to-face gap (m), mean over rounds",
          lambda f: f["min_face_gap_m"], False, False, 0.002),
    Bound("overlap", "sometimes even have overlapping; often overlap",
          "rounds with an object resting on another", lambda f: f["stacked"] >= 1, True, True, 0.50),
    Bound("scatter", "a pile that stays a pile",
          "rounds whose spread grows by more than 1 cm while settling",
          lambda f: f["spread_m"] - f["placed_spread_m"] > 0.01, True, False, 0.05),
)


def judge(rounds: pd.DataFrame, allowance: bool = False) -> pd.DataFrame:
    """One row per bound: its value on `rounds`, the limit and whether it holds. With
    `allowance`, a bound holds unless the sample contradicts it at 1 % one-sided (a binomial
    tail for a share of rounds, a normal interval for a mean): the test's small samples."""
    out = []
    for bound in SETUP3_BOUNDS:
        values = np.asarray(bound.per_round(rounds), float)
        values = values[np.isfinite(values)]
        n = len(values)
        value = float(values.mean()) if n else math.nan
        holds = value >= bound.limit if bound.at_least else value <= bound.limit
        if allowance and n:
            if bound.share:
                k = int(values.sum())
                # a share at least `limit` is contradicted by few flagged rounds, and vice versa
                tail = (k, n) if not bound.at_least else (0, k)  # P(X >= k) or P(X <= k)
                holds = _binomial_between(n, bound.limit, *tail) >= 0.01
            else:
                half = _Z99 * float(values.std(ddof=1)) / math.sqrt(n) if n > 1 else 0.0
                holds = (value + half >= bound.limit) if bound.at_least else (value - half <= bound.limit)
        out.append({"bound": bound.name, "paper": bound.paper, "statistic": bound.what,
                    "value": value, "limit": ("at least " if bound.at_least else "at most ")
                    + f"{bound.limit:g}", "rounds": n, "holds": bool(holds)})
    return pd.DataFrame(out)


def paper_runs() -> pd.DataFrame:
    """The paper's run-level statements of Setups 2 and 3 (`data/paper_runs.csv`): setup,
    whether exact or a lower bound, failures per run, runs, and the quote."""
    from importlib import resources

    text = resources.files("graspjax").joinpath("data/paper_runs.csv").read_text()
    return pd.read_csv(io.StringIO(text))


def round_failures(outcomes: pd.DataFrame) -> pd.DataFrame:
    """Failures per round: one row per (point, setup, round) of Setups 2 and 3 from
    `report.object_outcomes`' rows (each object once per round), with `failures`, `objects`."""
    rounds = outcomes[outcomes["setup"] > 1]
    keys = [c for c in ("point", "setup", "trial") if c in rounds.columns]
    failed = rounds.assign(failed=~rounds["success"].astype(bool))
    return failed.groupby(keys).agg(objects=("failed", "size"), failures=("failed", "sum")
                                    ).reset_index()


def _binomial_between(n: int, p: float, low: int, high: int) -> float:
    """P(low <= X <= high) for X ~ Binomial(n, p)."""
    return sum(math.comb(n, k) * p ** k * (1 - p) ** (n - k) for k in range(low, high + 1))


def consistency(outcomes: pd.DataFrame, setup: int, runs: int = 10) -> dict[str, float]:
    """How probable the paper's own run-level facts of a setup are under our rates (a check of a
    scene against the paper, never a choice of one). From `report.object_outcomes`' rows of one
    grid point:

    - Setup 3: every one of `runs` runs with 2 or more failures ("in all runs 2 or more
      failures occurred"), and every object's cell of `runs` trials between 50 and 70 %
      (Table 1's Setup 3 row), each object's rate taken as ours;
    - Setup 2: the printed counts of runs with 0 / 1 / 2 failures (3 / 5 / 3; 11 runs, as
      printed), their multinomial probability, and that of `runs` runs with at most 2.

    Also the shares of our rounds with 0, 1, 2 and 3+ failures."""
    part = outcomes[outcomes["setup"] == setup]
    per_round = round_failures(part)["failures"]
    share = [float((per_round == k).mean()) for k in (0, 1, 2)] + [float((per_round >= 3).mean())]
    out = {"rounds": float(len(per_round)), "share_0": share[0], "share_1": share[1],
           "share_2": share[2], "share_3_or_more": share[3]}
    if setup == 3:
        out["p_all_runs_2_or_more"] = (share[2] + share[3]) ** runs
        rates = part.groupby("object")["success"].mean()
        out["p_every_cell_50_to_70"] = float(np.prod([_binomial_between(runs, p, 5, 7)
                                                     for p in rates]))
    if setup == 2:
        counts = paper_runs().query("setup == 2")  # 0, 1 and 2 failures per run, as printed
        k = counts["runs"].astype(int).tolist()
        n = sum(k)
        out["p_printed_counts"] = (math.factorial(n) / math.prod(math.factorial(c) for c in k)
                                   * math.prod(s ** c for s, c in zip(share[:3], k, strict=True)))
        out["p_all_runs_at_most_2"] = (1 - share[3]) ** runs
    return out


def _per_setup(frame: pd.DataFrame, heading: str,
               line: Callable[[int, pd.DataFrame], str]) -> list[str]:
    """A markdown section: `heading`, then `line(setup, rows)` for Setups 2 and 3 where played;
    nothing where neither was."""
    played = [s for s in (2, 3) if (frame["setup"] == s).any()]
    if not played:
        return []
    return ["", heading, ""] + [line(s, frame[frame["setup"] == s]) for s in played]


def _consistency_line(setup: int, outcomes: pd.DataFrame) -> str:
    facts = consistency(outcomes, setup)
    shares = " / ".join(f"{100 * facts[k]:.0f}" for k in
                        ("share_0", "share_1", "share_2", "share_3_or_more"))
    if setup == 3:
        fact = (f"P(all 10 runs with 2 or more failures) = {facts['p_all_runs_2_or_more']:.2g}, "
                f"P(every cell of 10 trials within 50-70 %) = "
                f"{facts['p_every_cell_50_to_70']:.2g}")
    else:
        fact = (f"P(the printed 3 / 5 / 3 runs with 0 / 1 / 2 failures) = "
                f"{facts['p_printed_counts']:.2g}, P(10 runs with at most 2) = "
                f"{facts['p_all_runs_at_most_2']:.2g}")
    return (f"- Setup {setup} ({facts['rounds']:.0f} rounds; 0 / 1 / 2 / 3+ failures in {shares} "
            f"% of them): {fact}")


def consistency_lines(outcomes: pd.DataFrame) -> list[str]:
    """The paper's run-level facts of Setups 2 and 3 under our rates (`consistency`), one
    markdown line per setup played, for a run's Table 1 (one grid point)."""
    return _per_setup(outcomes, "The paper's run-level facts under our rates "
                      "(`report.density.consistency`; a check of the scene against the paper, "
                      "never a choice of one):", _consistency_line)


_CLEARANCE_BINS = ((-np.inf, 0.0, "below 0"), (0.0, 0.005, "0-5 mm"), (0.005, 0.02, "5-20 mm"),
                   (0.02, np.inf, "over 20 mm"))


def _rates(success: pd.Series, groups: list[tuple[str, pd.Series]]) -> str:
    """"name 68 % of 251, ..." for each (name, mask) of `success`."""
    return ", ".join(f"{name} {100 * success[mask].mean():.0f} % of {int(mask.sum())}"
                     if mask.any() else f"{name}: none" for name, mask in groups)


def _clutter_line(setup: int, part: pd.DataFrame) -> str:
    success = part["success"].astype(bool)
    clearance = part["finger_clearance_m"]
    kinds = [("touching another", part["target_touching"] > 0.5),
             ("touching none", part["target_touching"] < 0.5),
             ("resting on another", part["target_resting"] > 0.5),
             ("covered by another", part["target_covered"] > 0.5)]
    space = [(name, (clearance > low) & (clearance <= high)) for low, high, name in _CLEARANCE_BINS]
    return (f"- Setup {setup}: the target {_rates(success, kinds)}; free space at the open "
            f"fingers {_rates(success, space)}")


def target_clutter_lines(attempts: pd.DataFrame) -> list[str]:
    """Setups 2 and 3's success by how crowded the target was when the robot looked, from the
    attempt rows' ground-truth clutter columns (attribution only; `schema.ATTEMPT_COLUMNS`):
    touching another object or not, resting on another, covered by another, and the free space
    around the open fingers at the executed grasp. One markdown line per setup played."""
    if "target_touching" not in attempts.columns:  # runs made before these columns
        return []
    return _per_setup(attempts, "Success by how crowded the target was when the robot looked "
                      "(ground truth of `attempts.csv`, attribution only; success of n attempts):",
                      _clutter_line)
