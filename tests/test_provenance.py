"""What a result records of the code that made it, read back against git's own files."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

from graspjax import provenance
from graspjax.cli import main

CHECKOUT = Path(provenance.__file__).resolve().parents[1]


def _head_from_git_files() -> str:
    """The checkout's HEAD commit, read from .git's files (not through git's commands)."""
    git = CHECKOUT / ".git"
    head = (git / "HEAD").read_text().strip()
    if not head.startswith("ref: "):
        return head
    ref = head[len("ref: "):]
    if (git / ref).is_file():
        return (git / ref).read_text().strip()
    packed = (git / "packed-refs").read_text().splitlines()
    return next(line.split()[0] for line in packed if line.endswith(" " + ref))


def test_a_checkout_records_its_commit_and_every_result_its_source_digest():
    code = provenance.code_identity()
    assert code["digest"] == provenance.source_digest() and len(code["digest"]) == 64
    if (CHECKOUT / ".git").is_dir():  # a clone (CI, a user's checkout); not an installed wheel
        assert code["commit"] == _head_from_git_files()
        assert isinstance(code["dirty"], bool)


def test_the_package_outside_a_checkout_records_no_commit(tmp_path):
    copy = tmp_path / "graspjax"
    shutil.copytree(CHECKOUT / "graspjax", copy, ignore=shutil.ignore_patterns("__pycache__"))
    done = subprocess.run([sys.executable, "-c", "import json; from graspjax import provenance; "
                           "print(json.dumps(provenance.code_identity()))"],
                          cwd=tmp_path, capture_output=True, text=True, timeout=120)
    code = json.loads(done.stdout)
    assert code["commit"] is None and code["dirty"] is None
    assert code["digest"] == provenance.source_digest()  # the same sources: the same digest


def test_report_says_when_a_folder_was_made_by_other_code(tmp_path, capsys):
    rows = ("setup,object,trial,round,seed,success,outcome,reason\n"
            "1,a,0,,0,1,SUCCESS,SUCCESS\n")
    (tmp_path / "attempts.csv").write_text(rows)
    other = {"digest": "0" * 64, "commit": "1234567890abcdef", "dirty": True}
    (tmp_path / "config.json").write_text(json.dumps({"code": other}))
    assert main(["report", str(tmp_path)]) == 0
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert "was made by other code (commit 1234567890 with changes; this is " in err
    (tmp_path / "config.json").write_text(json.dumps({"code": provenance.code_identity()}))
    assert main(["report", str(tmp_path)]) == 0
    assert "other code" not in capsys.readouterr().err
