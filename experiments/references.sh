#!/usr/bin/env bash
# The reference results a CPU can make when no GPU is lent (labelled `_cpu_N`): Tables 1+2, Eq. 2's
# printed half-footprint against the paper preset, Setup 3's density sweep and the bin's size,
# and the methods on the same worlds. Each step runs one graspjax command into $OUT/NAME (default
# results/...), gzips its attempts and drops the Parquet copy (the committed folders keep CSV).
#   tables-PRESET  Tables 1+2, 100 trials per cell (results/PRESET_cpu_100)
#   eq2            the paper preset with Eq. 2 as printed (align.pixel_scale=printed), the same
#                  worlds as tables-paper (same seed, trials and batch): results/eq2_printed_cpu_100
#   density        Setup 3's pile from the paper's reading to Setup 2's gaps, paired, 100 rounds
#                  per point (results/setup3/density_cpu_100; experiments/setup3_density.py)
#   bin            Setup 3 in the bin at 14 / 18 / 24 cm, paired, 100 rounds per point
#                  (results/setup3/bin_size_cpu_100)
#   methods-PRESET the paper's method and the baselines on the same worlds, Tables 1+2, 30 trials
#                  per cell (results/methods/PRESET_cpu_30)
set -uo pipefail
out=${OUT:-results}
step() {  # step FOLDER COMMAND ARGS...: one graspjax command into $out/FOLDER
  local folder=$out/$1 start=$SECONDS
  shift
  python3 -m graspjax.cli "$@" --seed 0 --quiet --overwrite --out "$folder" > "$folder.log" 2>&1
  local code=$?
  echo "== $folder: exit $code after $((SECONDS - start)) s"
  if [ "$code" -ne 0 ]; then tail -n 5 "$folder.log"; return "$code"; fi
  gzip -f "$folder/attempts.csv" "$folder/rounds.csv" 2>/dev/null
  rm -f "$folder/attempts.parquet" "$folder.log"
}
for name in "$@"; do
  case "$name" in
    tables-*) step "${name#tables-}_cpu_100" run --table 1,2 --trials 100 --preset "${name#tables-}" ;;
    eq2) step eq2_printed_cpu_100 run --table 1,2 --trials 100 --preset paper \
      --set align.pixel_scale=printed ;;
    density) mkdir -p "$out/setup3" && step setup3/density_cpu_100 sweep --setup 3 --trials 100 \
      --paired --grid "layout.pile_gap_min:layout.pile_gap_max:layout.pile_push=\
-0.02:0:0.7,-0.02:0:0,0:0.01:0,0.005:0.03:0,0.02:0.05:0" ;;
    bin) mkdir -p "$out/setup3" && step setup3/bin_size_cpu_100 sweep --setup 3 --trials 100 \
      --paired --set layout.bin=true --grid layout.bin_size=0.14,0.18,0.24 ;;
    methods-*) mkdir -p "$out/methods" && step "methods/${name#methods-}_cpu_30" sweep --table 1,2 \
      --trials 30 --paired --preset "${name#methods-}" --grid method=paper,highest-pca,antipodal ;;
    *) echo "unknown step $name" >&2; exit 2 ;;
  esac
done
