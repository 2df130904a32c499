#!/usr/bin/env bash
# Re-alignment fixes and the studies of its parameters on the GPU machine (issue 22). MuJoCo
# goes along as wheels (../shared/gpu/README.md); every step writes into $OUT and ends with a
# short table. Steps (several per call: experiments/realign_fix_gpu.sh anchor-paper window):
#   anchor-paper      Tables 1+2, 300 trials, paper preset, paired: align.anchor=nearest,centre
#   anchor-realistic  the same, realistic preset
#   window            the sloped Setup 1 variant (procedure.view_tilt_deg=30), a-f, 300 trials,
#                     paired sweep of align.window_px=5,10,15,20,30
#   threshold         the same, align.distance_threshold=0.05,0.1,0.3,0.6,1.0
#   planes-sloped     perception only: first views of 3,000 sloped Setup 1 worlds per object,
#                     judged for window x threshold (5 x 5 grid points)
#   planes-bin        the same on the first views of 16,384 Setup 3 rounds
set -uo pipefail
out=${OUT:?set OUT to the folder that collects the results}
gj() { python3 -m graspjax.cli "$@"; }
sloped=(--setup 1 --objects abcdef --trials 300 --seed 0 --paired --quiet
        --set procedure.view_tilt_deg=30)
windows=align.window_px=5,10,15,20,30
thresholds=align.distance_threshold=0.05,0.1,0.3,0.6,1.0
keep() {  # pack a result folder, drop the bulky parts
  tar -C "$out" -czf "$out/$1.tar.gz" "$1" && rm -rf "${out:?}/$1"
}
for step in "$@"; do
  start=$SECONDS
  case "$step" in
    anchor-paper|anchor-realistic)
      preset=${step#anchor-}
      gj sweep --table 1,2 --trials 300 --seed 0 --preset "$preset" --paired --quiet \
        --grid align.anchor=nearest,centre --out "$out/anchor_$preset" > "$out/anchor_$preset.log" 2>&1
      echo "== $step: exit $? after $((SECONDS - start)) s"; keep "anchor_$preset" ;;
    window)
      gj sweep "${sloped[@]}" --grid "$windows" --out "$out/sloped_window" > "$out/sloped_window.log" 2>&1
      echo "== $step: exit $? after $((SECONDS - start)) s"; keep sloped_window ;;
    threshold)
      gj sweep "${sloped[@]}" --grid "$thresholds" --out "$out/sloped_threshold" > "$out/sloped_threshold.log" 2>&1
      echo "== $step: exit $? after $((SECONDS - start)) s"; keep sloped_threshold ;;
    planes-sloped)
      gj planes --setup 1 --objects abcdef --trials 3000 --seed 0 --quiet \
        --set procedure.view_tilt_deg=30 --grid "$windows" --grid "$thresholds" \
        --out "$out/planes_sloped" > "$out/planes_sloped.log" 2>&1
      echo "== planes sloped: exit $? after $((SECONDS - start)) s"; tail -n 1 "$out/planes_sloped.log"
      keep planes_sloped ;;
    planes-bin)
      gj planes --setup 3 --objects abcdef --trials 16384 --seed 0 --quiet \
        --grid "$windows" --grid "$thresholds" --out "$out/planes_bin" > "$out/planes_bin.log" 2>&1
      echo "== planes bin: exit $? after $((SECONDS - start)) s"; tail -n 1 "$out/planes_bin.log"
      keep planes_bin ;;
    *) echo "unknown step $step" >&2; exit 2 ;;
  esac
done
