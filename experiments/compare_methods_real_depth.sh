#!/usr/bin/env bash
# `graspjax detect --method paper|highest-pca|antipodal` on every development capture, both
# presets, judged by experiments/judge_real_depth.py: the 15 gqcnn captures of
# ../shared/real_depth/ with the workspace boxes its README suggests, and the 8 captures of
# ../shared/real_depth/more/ (experiments/real_depth_more.py). Run from the repository root:
#   bash experiments/compare_methods_real_depth.sh results/real_depth/methods [VARIANT ...]
# Variants (all four when none is given): paper (with its contour search), paper-tbeam (the
# T-beam's placements alone: --set image.contour_search=false), highest-pca, antipodal.
# Writes OUT/VARIANT/PRESET/<set>/results.{csv,json}, each set's judgement.txt, and
# OUT/summary.csv (per method, preset and set: images, best grasps found, best grasps that
# straddle, questionable ones). The captures stay outside the repository.
set -euo pipefail
out=${1:?give the output folder}
shift
variants=${*:-paper paper-tbeam highest-pca antipodal}
R=../shared/real_depth
for variant in $variants; do
  case $variant in
    paper-tbeam) method=paper; extra=(--set image.contour_search=false) ;;
    paper|highest-pca|antipodal) method=$variant; extra=() ;;
    *) echo "unknown variant $variant" >&2; exit 2 ;;
  esac
  for preset in paper realistic; do
    dir=$out/$variant/$preset
    mkdir -p "$dir"
    graspjax detect $R/primesense_single/depth_*.npy --intrinsics $R/primesense.intr \
      --roi 60,20,600,350 --top 2 --preset $preset --method $method "${extra[@]}" --quiet \
      --out "$dir/primesense_single" > /dev/null
    graspjax detect $R/primesense_clutter/depth_*.npy --intrinsics $R/primesense.intr \
      --roi 60,20,600,350 --top 2 --preset $preset --method $method "${extra[@]}" --quiet \
      --out "$dir/primesense_clutter" > /dev/null
    graspjax detect $R/phoxi_clutter/depth_*.npy --intrinsics $R/phoxi.intr \
      --roi 70,50,470,320 --top 2 --preset $preset --method $method "${extra[@]}" --quiet \
      --out "$dir/phoxi_clutter" > /dev/null
    python experiments/judge_real_depth.py "$dir"/*/results.json > "$dir/judgement.txt"
    python experiments/real_depth_more.py --out "$dir/more" --preset $preset -- \
      --method $method "${extra[@]}" > /dev/null
    echo "== $variant, $preset"; grep "best grasps straddle" "$dir/judgement.txt" "$dir/more/judgement.txt"
  done
done
python3 - "$out" <<'PY'
import re
import sys
from pathlib import Path

out = Path(sys.argv[1])
rows = ["variant,preset,set,images,found,straddle,questionable"]
for judgement in sorted(out.glob("*/*/judgement.txt")) + sorted(out.glob("*/*/more/judgement.txt")):
    parts = judgement.relative_to(out).parts
    method, preset = parts[0], parts[1]
    sets: dict = {}
    for line in judgement.read_text().splitlines():
        m = re.match(r"(\S+)/results\.json (\S+?)(?: rank (\d+))?: (\w[\w ]*)", line)
        if not m or (m.group(3) not in (None, "1")):
            continue
        name = Path(m.group(1)).name
        s = sets.setdefault(name, [0, 0, 0, 0])
        s[0] += 1
        verdict = m.group(4)
        s[1] += not verdict.startswith("no grasp")
        s[2] += verdict.startswith("straddles")
        s[3] += verdict.startswith("QUESTIONABLE")
    rows += [f"{method},{preset},{name},{','.join(map(str, s))}" for name, s in sets.items()]
(out / "summary.csv").write_text("\n".join(rows) + "\n")
print("\n".join(rows))
PY
