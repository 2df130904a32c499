"""How much the judge's verdicts rest on where it puts the finger places.

    python experiments/judge_finger_offsets.py OFFSET[,OFFSET...] results.json ...

`judge_real_depth.py` puts each finger place 6 mm beyond the gripped band's half width. This
judges every ranked grasp of the given results.json files again with each OFFSET (m) instead
and prints, per offset, how many best (rank 1) and second-ranked verdicts change, and each
change with the finger drops it saw. Reads the images named in the records.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from judge_real_depth import FINGER_OFFSET, judge


def main(argv: list[str]) -> int:
    if len(argv) < 2:
        print(__doc__.strip().splitlines()[2].strip(), file=sys.stderr)
        return 2
    try:
        offsets = [float(x) for x in argv[0].split(",")]
    except ValueError:
        print(f"offsets must be numbers (m), comma-separated: got {argv[0]!r}", file=sys.stderr)
        return 2
    if not all(x >= 0 for x in offsets):
        print(f"offsets must be >= 0 (m): got {argv[0]!r}", file=sys.stderr)
        return 2
    grasps = []  # (file, image, rank, record, candidate)
    for path in argv[1:]:
        records = json.loads(Path(path).read_text())
        for rec in records if isinstance(records, list) else [records]:
            grasps += [(path, Path(rec["image"]).name, c["rank"], rec, c) for c in rec["candidates"]]
    base = [judge(rec, c, finger_offset=FINGER_OFFSET)[0] for *_, rec, c in grasps]
    print(f"{len(grasps)} ranked grasps; verdicts at {1000 * FINGER_OFFSET:g} mm: "
          f"{sum(base)} straddle")
    for offset in offsets:
        changed = {1: 0, 2: 0}
        lines = []
        for (path, name, rank, rec, c), before in zip(grasps, base, strict=True):
            ok, text = judge(rec, c, finger_offset=offset)
            if ok != before:
                changed[min(rank, 2)] += 1
                lines.append(f"  {path} {name} rank {rank}: "
                             f"{'QUESTIONABLE -> straddles' if ok else 'straddles -> QUESTIONABLE'}"
                             f" ({text})")
        ranks = [rank for _, _, rank, _, _ in grasps]
        print(f"{1000 * offset:g} mm: {changed[1]} of {ranks.count(1)} best and {changed[2]} of "
              f"{len(ranks) - ranks.count(1)} lower-ranked verdicts change")
        print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
