"""Setup 3's bounds and the paper's run-level facts (`report/density.py`), on hand-made rounds
whose answers are computed here by hand."""

import math

import pandas as pd
import pytest

from graspjax.report.density import consistency, consistency_lines, judge, paper_runs, target_clutter_lines


def _rounds(**columns):
    base = {"touching_fraction": 1.0, "near_fraction": 1.0, "stacked": 1, "min_face_gap_m": 0.0,
            "spread_m": 0.15, "placed_spread_m": 0.15}
    n = max(len(v) for v in columns.values())
    return pd.DataFrame({k: columns.get(k, [v] * n) for k, v in base.items()})


def test_a_share_bound_holds_strictly_and_with_the_binomial_allowance():
    """Overlap (>= 50 % of rounds with an object resting on another): 4 of 12 rounds is 33 %,
    so it fails strictly; P(X <= 4 | 12, 0.5) = 794 / 4096 = 0.19 > 1 %, so a sample of 12
    does not contradict it; 1 of 12 does (13 / 4096 = 0.003)."""
    four = _rounds(stacked=[1] * 4 + [0] * 8)
    strict = judge(four).set_index("bound")
    assert strict.loc["overlap", "value"] == pytest.approx(4 / 12) and not strict.loc["overlap", "holds"]
    assert judge(four, allowance=True).set_index("bound").loc["overlap", "holds"]
    one = _rounds(stacked=[1] + [0] * 11)
    assert not judge(one, allowance=True).set_index("bound").loc["overlap", "holds"]


def test_a_mean_bound_uses_a_one_sided_normal_allowance():
    """Near (mean >= 0.8): values 0.7 and 0.8 alternating over 10 rounds have mean 0.75 and
    sample sd 0.0527; 0.75 + 2.326 * 0.0527 / sqrt(10) = 0.789 < 0.8: contradicted."""
    rounds = _rounds(near_fraction=[0.7, 0.8] * 5)
    row = judge(rounds, allowance=True).set_index("bound").loc["near"]
    assert row["value"] == pytest.approx(0.75) and not row["holds"]
    wide = _rounds(near_fraction=[0.5, 1.0] * 5)  # mean 0.75, sd 0.264: 0.75 + 0.194 >= 0.8
    assert judge(wide, allowance=True).set_index("bound").loc["near", "holds"]


def test_scatter_counts_rounds_whose_spread_grew_by_more_than_a_centimetre():
    rounds = _rounds(spread_m=[0.15, 0.161, 0.159, 0.10], placed_spread_m=[0.15] * 4)
    row = judge(rounds).set_index("bound").loc["scatter"]
    assert row["value"] == pytest.approx(1 / 4) and not row["holds"]


def _outcomes(setup, failures_per_round, objects="abcdef"):
    """Object outcomes of rounds with the given failures each (the first objects fail)."""
    rows = []
    for trial, failed in enumerate(failures_per_round):
        for i, obj in enumerate(objects):
            rows.append({"point": 0, "setup": setup, "trial": trial, "object": obj,
                         "success": i >= failed})
    return pd.DataFrame(rows)


def test_setup3s_run_level_facts_by_hand():
    """Rounds with 0, 1, 2, 3 failures, one each: P(2 or more) = 1/2, so all 10 runs have 2 or
    more with 0.5^10. Object a fails in three of the four rounds (25 %), b in two (50 %), c in one
    (75 %), d-f never (100 %): a cell of 10 trials within 5-7 successes is impossible at 100 %,
    so every cell within 50-70 % has probability 0."""
    facts = consistency(_outcomes(3, [0, 1, 2, 3]), setup=3)
    assert [facts[f"share_{k}"] for k in (0, 1, 2)] == [0.25, 0.25, 0.25]
    assert facts["share_3_or_more"] == 0.25
    assert facts["p_all_runs_2_or_more"] == pytest.approx(0.5 ** 10)
    assert facts["p_every_cell_50_to_70"] == 0.0
    # Objects a and b alone (b fails in half the rounds, a in three quarters): the cells'
    # probabilities multiply: P(5 <= X <= 7) for p = 1/4 and for p = 1/2.
    two = consistency(_outcomes(3, [0, 1, 2, 2], objects="ab"), setup=3)
    def between(p):
        return sum(math.comb(10, k) * p ** k * (1 - p) ** (10 - k) for k in (5, 6, 7))
    assert two["p_every_cell_50_to_70"] == pytest.approx(between(0.25) * between(0.5))


def test_setup2s_printed_counts_by_hand():
    """The paper's 3 / 5 / 3 runs with 0 / 1 / 2 failures (11 runs as printed): with our shares
    1/2, 1/4, 1/4 (and none with 3 or more) their multinomial probability is
    11! / (3! 5! 3!) 0.5^3 0.25^5 0.25^3 = 9240 * 2^-19."""
    assert paper_runs().query("setup == 2")["runs"].tolist() == [3, 5, 3]
    facts = consistency(_outcomes(2, [0, 0, 1, 2]), setup=2)
    assert facts["p_printed_counts"] == pytest.approx(9240 * 2.0 ** -19)
    assert facts["p_all_runs_at_most_2"] == 1.0


def test_a_runs_table1_states_the_facts_it_computed_by_hand():
    """The lines `table1.md` carries: Setup 2's and Setup 3's hand-computed probabilities above
    (9240 * 2^-19 = 0.0176, 0.5^10 = 0.00098) and the shares of rounds by failures."""
    frame = pd.concat([_outcomes(2, [0, 0, 1, 2]), _outcomes(3, [0, 1, 2, 3])])
    lines = consistency_lines(frame)
    assert lines[3] == ("- Setup 2 (4 rounds; 0 / 1 / 2 / 3+ failures in 50 / 25 / 25 / 0 % of "
                        "them): P(the printed 3 / 5 / 3 runs with 0 / 1 / 2 failures) = 0.018, "
                        "P(10 runs with at most 2) = 1")
    assert lines[4].startswith("- Setup 3 (4 rounds; 0 / 1 / 2 / 3+ failures in 25 / 25 / 25 / "
                               "25 % of them): P(all 10 runs with 2 or more failures) = 0.00098,")
    assert consistency_lines(_outcomes(1, [0, 1])) == []


def test_success_by_the_targets_clutter_counts_by_hand():
    """Four Setup 3 attempts: two touching (one succeeds), one alone (succeeds), one with no
    target (NaN, in neither group); one resting; clearances -1 mm, 3 mm, 3 mm and none."""
    nan = float("nan")
    frame = pd.DataFrame({"setup": 3, "success": [True, False, True, False],
                          "target_touching": [1.0, 1.0, 0.0, nan],
                          "target_resting": [1.0, 0.0, 0.0, nan],
                          "target_covered": [0.0, 0.0, 0.0, nan],
                          "finger_clearance_m": [-0.001, 0.003, 0.003, nan]})
    (line,) = target_clutter_lines(frame)[3:]
    assert line == ("- Setup 3: the target touching another 50 % of 2, touching none 100 % of 1, "
                    "resting on another 100 % of 1, covered by another: none; free space at the "
                    "open fingers below 0 100 % of 1, 0-5 mm 50 % of 2, 5-20 mm: none, over "
                    "20 mm: none")
    assert target_clutter_lines(frame.assign(setup=1)) == []
