"""`graspjax detect` on the development captures of `../shared/real_depth/more/` (sd-maskrcnn's
bins seen by PhoXi, Ensenso and PrimeSense sensors; NVlabs' tilted tables), each with its own
intrinsics and workspace box from `cases.json`, then judged (`judge_real_depth.py`).

    python experiments/real_depth_more.py --out results/real_depth/more [--preset realistic]
        [-- extra graspjax detect arguments, e.g. --method antipodal]

The captures are not part of the repository: each is written as an .npy into `--images`
(default: a folder under the system's temporary folder), which the records name and the judge
reads. Writes one folder per case under `--out` (results.csv, results.json) and judgement.txt.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

MORE = Path(__file__).resolve().parents[1].parent / "shared" / "real_depth" / "more"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", required=True, help="folder of the results")
    parser.add_argument("--preset", default="paper", choices=["paper", "realistic"])
    parser.add_argument("--images", default=str(Path(tempfile.gettempdir()) / "graspjax_more"),
                        help="where the captures are written as .npy (outside the repository)")
    parser.add_argument("--more", default=str(MORE), help="the folder of cases.json, more.npz")
    parser.add_argument("--only", default="", help="only the cases whose name starts so (sdm)")
    parser.add_argument("--no-roi", action="store_true",
                        help="leave the cases' workspace boxes out (with -- --bin: the whole image)")
    parser.add_argument("extra", nargs=argparse.REMAINDER,
                        help="more graspjax detect arguments (after --)")
    args = parser.parse_args()
    more = Path(args.more)
    if not (more / "cases.json").is_file():
        print(f"no development captures in {more}", file=sys.stderr)
        return 1
    cases = json.loads((more / "cases.json").read_text())["cases"]
    images, out = Path(args.images), Path(args.out)
    images.mkdir(parents=True, exist_ok=True)
    out.mkdir(parents=True, exist_ok=True)
    with np.load(more / "more.npz") as archive:
        for case in cases:
            if not case["name"].startswith(args.only):
                continue
            path = images / f"{case['name']}.npy"
            np.save(path, archive[case["key"]].astype(np.float32))
            command = [sys.executable, "-m", "graspjax.cli", "detect", str(path),
                       "--fx", str(case["fx"]), "--fy", str(case["fy"]),
                       "--cx", str(case["cx"]), "--cy", str(case["cy"]),
                       *([] if args.no_roi else ["--roi", ",".join(str(v) for v in case["roi"])]),
                       "--top", "2",
                       "--preset", args.preset, "--quiet", "--out", str(out / case["name"]),
                       *[a for a in args.extra if a != "--"]]
            done = subprocess.run(command, capture_output=True, text=True)
            if done.returncode:
                print(done.stderr.strip(), file=sys.stderr)
                return done.returncode
    judge = Path(__file__).with_name("judge_real_depth.py")
    verdict = subprocess.run([sys.executable, str(judge),
                              *sorted(str(p) for p in out.glob("*/results.json"))],
                             capture_output=True, text=True, check=True).stdout
    (out / "judgement.txt").write_text(verdict)
    print(verdict)
    return 0


if __name__ == "__main__":
    sys.exit(main())
