"""README and docs/ say what is true now: no session numbers, no commit hashes (history
belongs in git). results/ and experiments/ name no session or issue either (a measurement may
name the commit it measured)."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
HISTORY = [
    (re.compile(r"\bstop \d", re.IGNORECASE), "a session number"),
    (re.compile(r"\bissue \d", re.IGNORECASE), "an issue number"),
    # a commit: 7 to 40 hex digits with a letter and a digit, standing alone
    (re.compile(r"(?<![\w#/.-])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,40}(?![\w/-])"),
     "a commit hash"),
]


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_a_page_narrates_no_history(page):
    found = [f"{page.name}:{n}: {what} ({match.group(0)!r})"
             for n, line in enumerate(page.read_text().splitlines(), 1)
             for pattern, what in HISTORY for match in pattern.finditer(line)]
    assert not found, "; ".join(found)


def test_the_history_patterns_catch_what_they_name():
    text = "made at stop 82 from commit 94c4abf, see issue 75; 0x1f, #1f77b4, 2026 and dead bee"
    caught = [what for pattern, what in HISTORY for _ in pattern.finditer(text)]
    assert caught == ["a session number", "an issue number", "a commit hash"]


RECORDS = sorted(p for folder in ("results", "experiments") for p in (ROOT / folder).rglob("*")
                 if p.suffix in (".md", ".txt", ".py", ".sh"))


def test_results_and_experiments_name_no_session_or_issue():
    found = [f"{page.relative_to(ROOT)}:{n}: {what} ({match.group(0)!r})"
             for page in RECORDS
             for n, line in enumerate(page.read_text().splitlines(), 1)
             for pattern, what in HISTORY[:2] for match in pattern.finditer(line)]
    assert RECORDS and not found, "; ".join(found)
