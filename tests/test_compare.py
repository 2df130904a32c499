"""`graspjax report --compare` (`report/compare.py`): paired tables checked by hand."""

import json
import math
import os

import pandas as pd
import pytest

from graspjax.cli import main


def _run(folder, seed, setup1_a, setup1_b, rescued_a=(), point_values=None):
    """A run folder: object a and b alone (Setup 1), one attempt per trial, success per trial
    as given; `rescued_a`: trials of a that succeeded after a re-alignment. `point_values`: a
    paired sweep instead, {point: (a's successes, b's successes)} under `cfg.align.window_px`."""
    folder.mkdir()
    points = point_values or {0: (setup1_a, setup1_b)}
    rows = []
    for point, (a, b) in points.items():
        for obj, outcomes in (("a", a), ("b", b)):
            for trial, success in enumerate(outcomes):
                rows.append({"point": point, "setup": 1, "object": obj, "trial": trial,
                             "round": trial, "attempt": 0, "seed": seed, "success": success,
                             "outcome": "SUCCESS" if success else "MISSED",
                             "reason": "SUCCESS" if success else "MISSED",
                             "rescued": int(obj == "a" and trial in rescued_a and success),
                             "reorientations": int(obj == "a" and trial in rescued_a),
                             "cfg.align.window_px": 10 + 5 * point})
    pd.DataFrame(rows).to_csv(folder / "attempts.csv", index=False)
    meta = {"seed": seed, "paired": True, "versions": {"graspjax": "test"}}
    (folder / "config.json").write_text(json.dumps(meta))
    return folder


def test_two_runs_of_the_same_worlds_compare_paired_by_hand(tmp_path, capsys):
    """a: 1 1 0 0 against 1 0 1 1 (2 gained, 1 lost: z = 1 / sqrt 3, +25 points); b the same
    in both (no pair differs: z 0); the reference's rescued trial counts as rescued."""
    first = _run(tmp_path / "first", 0, [1, 1, 0, 0], [1, 0, 0, 0], rescued_a=(1,))
    second = _run(tmp_path / "second", 0, [1, 0, 1, 1], [1, 0, 0, 0])
    assert main(["report", "--compare", str(first), str(second)]) == 0
    out = capsys.readouterr().out
    table = [line for line in out.splitlines() if line.startswith("| ")]
    assert table[0].startswith("| point | Setup 1, a-f: success (first view + rescued)")
    # Setup 1 a-f pools a and b: the reference 3 of 8 (one rescued), the other 4 of 8.
    assert table[1] == "| first | 37.5 % (25.0 + 12.5) |"
    z = (2 - 1) / math.sqrt(3)
    assert table[2].startswith(f"| second | 50.0 % (50.0 + 0.0); +12.5 (2 gained / 1 lost of 8), "
                               f"z +{z:.1f}, p 1, resolves ")
    assert "Paired against first" in out


def test_a_paired_sweep_s_points_compare_with_its_first(tmp_path, capsys):
    sweep = _run(tmp_path / "sweep", 0, None, None,
                 point_values={0: ([1, 1, 1, 1], [1, 1, 0, 0]), 1: ([0, 0, 1, 1], [1, 1, 0, 0])})
    assert main(["report", "--compare", str(sweep)]) == 0
    table = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| ")]
    assert table[1].startswith("| align.window_px=10 | 75.0 %")
    # Two of a's trials lost, none gained: z = -2 / sqrt 2.
    assert table[2].startswith(f"| align.window_px=15 | 50.0 % (50.0 + 0.0); -25.0 (0 gained / "
                               f"2 lost of 8), z {-2 / math.sqrt(2):+.1f}")


@pytest.mark.parametrize("case, message", [
    ("seeds", "the runs play other worlds (seeds"),
    ("sweep among runs", "is a sweep of 2 points: compare its points with --compare"),
    ("one point", "holds one grid point: give the runs to compare with it"),
    ("both", "give a folder to report, or --compare DIR ... (not both)"),
    ("debug", "--debug draws one folder's attempts: not with --compare"),
    ("missing", "no such directory"),
    ("not UTF-8", "b\\udcffd': the folder's name is not UTF-8 text (rename it)"),
])
def test_what_cannot_be_compared_is_one_line_exit_2(tmp_path, capsys, case, message):
    first = _run(tmp_path / "first", 0, [1, 0], [1, 1])
    other = _run(tmp_path / "other", 1, [1, 0], [1, 1])
    sweep = _run(tmp_path / "sweep", 0, None, None, point_values={0: ([1], [1]), 1: ([0], [1])})
    args = {"seeds": ["--compare", str(first), str(other)],
            "sweep among runs": ["--compare", str(first), str(sweep)],
            "one point": ["--compare", str(first)],
            "both": [str(first), "--compare", str(first), str(other)],
            "debug": ["--compare", str(sweep), "--debug", "1"],
            "missing": ["--compare", str(first), str(tmp_path / "nowhere")],
            "not UTF-8": ["--compare", str(first), str(_run(tmp_path / os.fsdecode(b"b\xffd"), 0,
                                                            [1, 0], [1, 1]))]}[case]
    assert main(["report", *args]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1
