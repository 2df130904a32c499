"""The output schema and the integer codes: labels derived from the enums, no JAX imported."""

import ast
import pathlib

import pandas as pd

from graspjax.codes import Outcome, Reason, Surface
from graspjax.schema import REASON_LABELS, SURFACE_LABELS, TIMINGS_COLUMNS, sort_attempts

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
