#!/usr/bin/env bash
# results/jaw_sweep/: the simulated procedure with and without the real-image detector's jaws
# check (`detect.jaw_sweep`: each view's grasp swept down a height map of the view,
# perception.jaws.admit_by_jaws), paired on the same settled worlds, Tables 1+2, both presets,
# TRIALS per cell (default 300), PRESETS (default "paper realistic"). DEVICE=gpu (one GPU; MuJoCo as wheels, ../shared/gpu/README.md)
# packs each folder into $OUT/NAME.tgz; DEVICE=cpu writes results/jaw_sweep.
set -uo pipefail
device=${DEVICE:-cpu}
trials=${TRIALS:-300}
case "$device" in
  cpu) out=${OUT:-results/jaw_sweep} ;;
  gpu) out=${OUT:?set OUT to the folder that collects the results} ;;
  *) echo "DEVICE must be cpu or gpu" >&2; exit 2 ;;
esac
mkdir -p "$out"
for preset in ${PRESETS:-paper realistic}; do
  name=${preset}_${device}_$trials start=$SECONDS
  python3 -m graspjax.cli sweep --table 1,2 --trials "$trials" --paired --preset "$preset" \
    --grid detect.jaw_sweep=false,true --seed 0 --quiet --overwrite --out "$out/$name" \
    > "$out/$name.log" 2>&1
  code=$?
  echo "== $name: exit $code after $((SECONDS - start)) s"
  tail -n 2 "$out/$name.log"
  [ "$code" -eq 0 ] || exit "$code"
  python3 -c "import sys; from graspjax.report.files import keep_attempts; from graspjax.schema import STUDY_OMITS; keep_attempts(sys.argv[1], STUDY_OMITS)" \
    "$out/$name"
  gzip -f "$out/$name/rounds.csv" 2>/dev/null
  rm -f "$out/$name.log"
  python3 experiments/realign_studies.py "$out/$name" > "$out/$name/study.md"
  if [ "$device" = gpu ]; then
    tar -C "$out" -czf "$out/$name.tgz" "$name" && rm -rf "$out/$name"
  fi
done
