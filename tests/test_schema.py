"""The output schema and the integer codes: labels derived from the enums, no JAX imported."""

import ast
import pathlib

import pandas as pd

from graspjax.codes import Outcome, Reason, Surface
from graspjax.schema import (
    ATTEMPT_COLUMNS,
    REASON_LABELS,
    ROUND_COLUMNS,
    SURFACE_LABELS,
    TIMINGS_COLUMNS,
    attempt_columns,
    outputs_markdown,
    sort_attempts,
)

ROOT = pathlib.Path(__file__).resolve().parent.parent / "graspjax"


def test_schema_and_codes_import_neither_jax_nor_the_simulator():
    for name in ("schema.py", "codes.py"):
        tree = ast.parse((ROOT / name).read_text())
        imported = {node.module if isinstance(node, ast.ImportFrom) else alias.name
                    for node in ast.walk(tree) if isinstance(node, ast.Import | ast.ImportFrom)
                    for alias in node.names}
        assert imported <= {"__future__", "enum", "numpy", "pandas", "graspjax.codes"}, name


def test_labels_follow_the_enums():
    assert [SURFACE_LABELS[s + 1] for s in Surface] == ["", "target", "other object", "table",
                                                        "bin"]
    assert REASON_LABELS[Reason.SLIPPED] == "SLIPPED" == Outcome.SLIPPED.name
    assert REASON_LABELS[Reason.DETECT_NO_ROOM] == "detection: NO_ROOM"
    assert REASON_LABELS[Reason.ALIGN_TOO_FEW_INLIERS] == "alignment: TOO_FEW_INLIERS"
    assert REASON_LABELS[Reason.NO_TARGET] == "no target"


def test_attempts_sort_unattempted_objects_last():
    frame = pd.DataFrame({"point": [0, 0, 0], "setup": [2, 2, 2], "trial": [0, 0, 0],
                          "attempt": [-1, 1, 0], "object": ["a", "b", "c"]})
    assert list(sort_attempts(frame)["object"]) == ["c", "b", "a"]
    assert TIMINGS_COLUMNS[0] == "chunk" and len(set(TIMINGS_COLUMNS)) == len(TIMINGS_COLUMNS)


def test_attempts_sort_as_pandas_sorts_them_with_missing_objects_last():
    """The canonical order against pandas' stable sort on the same keys, on shuffled rows with
    ties, unattempted rows and rows without an object."""
    import numpy as np

    rng = np.random.default_rng(1)
    n = 400
    frame = pd.DataFrame({"point": rng.integers(0, 3, n), "setup": rng.integers(1, 4, n),
                          "trial": rng.integers(0, 5, n), "attempt": rng.integers(-1, 4, n),
                          "object": rng.choice(["a", "b", "l", None], n),
                          "row": np.arange(n)})
    keyed = frame.assign(attempt_order=frame["attempt"].where(frame["attempt"] >= 0, 99))
    reference = keyed.sort_values(["point", "setup", "trial", "attempt_order", "object"],
                                  kind="stable", na_position="last")
    assert list(sort_attempts(frame)["row"]) == list(reference["row"])


def test_docs_outputs_md_is_the_schema():
    """docs/outputs.md lists every column of every file, as schema.py describes them (regenerate:
    python3 -c "from graspjax.schema import outputs_markdown; print(outputs_markdown(), end='')"
    > docs/outputs.md)."""
    assert (ROOT.parent / "docs" / "outputs.md").read_text() == outputs_markdown()
    assert all(text.strip() for text in (*ATTEMPT_COLUMNS.values(), *ROUND_COLUMNS.values()))


def test_the_header_expands_the_re_alignments_and_the_grid_keys():
    header = attempt_columns(2, ["align.window_px"])
    assert header[:4] == ["run_id", "point", "method", "setup"]
    assert [c for c in header if c.startswith("realign")][-1] == "realign2_view_tilt_deg"
    assert header[-1] == "cfg.align.window_px" and not any("{" in c for c in header)
