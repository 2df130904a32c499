#!/usr/bin/env bash
# The reference results (labelled `_DEVICE_TRIALS`): Tables 1+2, Eq. 2's printed half-footprint
# against the paper preset, Setup 3's density sweep and the bin's size, and the methods on the
# same worlds. DEVICE=gpu (one GPU; MuJoCo as wheels, ../shared/gpu/README.md) runs 1,000 trials
# per cell (the methods 300) and packs each folder into $OUT/NAME.tgz, as the GPU machine returns
# at most 8 files; DEVICE=cpu (default) runs 100 (the methods 30) into results/. Each step runs
# one graspjax command into $OUT/FOLDER, keeps its attempts as compact Parquet in place of the
# CSV (report.files.keep_attempts) and gzips its rounds. LIMIT=SECONDS stops a step that runs longer (its parts stay:
# `--resume` continues it).
#   tables-PRESET  Tables 1+2 (results/PRESET_DEVICE_N)
#   eq2            the paper preset with Eq. 2 as printed (align.pixel_scale=printed), the same
#                  worlds as tables-paper (same seed, trials and batch): results/eq2_printed_DEVICE_N
#   density        Setup 3's pile from the paper's reading (and outlines placed overlapping by up to
#                  2 cm, denser) to Setup 2's gaps, paired
#                  (results/setup3/density_DEVICE_N; experiments/setup3_density.py)
#   bin            Setup 3 in the bin at 14 / 18 / 24 cm, paired (results/setup3/bin_size_DEVICE_N)
#   bin-small-hand the same bins and worlds with the small hand (6 cm opening, 1 cm x 6 mm fingers;
#                  the default is Franka-sized): results/setup3/bin_small_hand_DEVICE_N
#   methods-PRESET the paper's method and the baselines on the same worlds, Tables 1+2
#                  (results/methods/PRESET_DEVICE_N)
set -uo pipefail
device=${DEVICE:-cpu}
case "$device" in
  cpu) trials=100; method_trials=30; out=${OUT:-results} ;;
  gpu) trials=1000; method_trials=300; out=${OUT:?set OUT to the folder that collects the results} ;;
  *) echo "DEVICE must be cpu or gpu" >&2; exit 2 ;;
esac
step() {  # step FOLDER COMMAND ARGS...: one graspjax command into $out/FOLDER
  local folder=$out/$1 start=$SECONDS
  shift
  mkdir -p "$(dirname "$folder")"
  ${LIMIT:+timeout "$LIMIT"} python3 -m graspjax.cli "$@" --seed 0 --quiet --overwrite --out "$folder" > "$folder.log" 2>&1
  local code=$?
  echo "== $folder: exit $code after $((SECONDS - start)) s"
  tail -n 2 "$folder.log"
  if [ "$code" -ne 0 ]; then return "$code"; fi
  # the rows as compact Parquet; a comparison of methods, like a parameter study, without the
  # columns no comparison reads (schema.STUDY_OMITS)
  python3 -c "import sys; from graspjax.report.files import keep_attempts; from graspjax.schema import STUDY_OMITS; keep_attempts(sys.argv[1], STUDY_OMITS if '/methods/' in sys.argv[1] else ())" \
    "$folder" || return 1
  gzip -f "$folder/rounds.csv" 2>/dev/null
  rm -f "$folder.log"
  if [ "$device" = gpu ]; then
    tar -C "$(dirname "$folder")" -czf "$out/$(basename "$folder").tgz" "$(basename "$folder")" \
      && rm -rf "$folder"
  fi
}
for name in "$@"; do
  case "$name" in
    tables-*) step "${name#tables-}_${device}_$trials" run --table 1,2 --trials "$trials" \
      --preset "${name#tables-}" ;;
    eq2) step "eq2_printed_${device}_$trials" run --table 1,2 --trials "$trials" --preset paper \
      --set align.pixel_scale=printed ;;
    density) step "setup3/density_${device}_$trials" sweep --setup 3 --trials "$trials" --paired \
      --grid "layout.pile_gap_min:layout.pile_gap_max:layout.pile_push=\
0:0:0.7,-0.02:0:0.7,-0.02:0:0,0:0.01:0,0.005:0.03:0,0.02:0.05:0" ;;
    bin) step "setup3/bin_size_${device}_$trials" sweep --setup 3 --trials "$trials" --paired \
      --set layout.bin=true --grid layout.bin_size=0.14,0.18,0.24 ;;
    bin-small-hand) step "setup3/bin_small_hand_${device}_$trials" sweep --setup 3 \
      --trials "$trials" --paired --set layout.bin=true --set gripper.opening=0.06 \
      --set gripper.finger_width=0.01 --set gripper.finger_thickness=0.006 \
      --grid layout.bin_size=0.14,0.18,0.24 ;;
    methods-*) step "methods/${name#methods-}_${device}_$method_trials" sweep --table 1,2 \
      --trials "$method_trials" --paired --preset "${name#methods-}" \
      --grid method=paper,highest-pca,antipodal ;;
    *) echo "unknown step $name" >&2; exit 2 ;;
  esac
done
