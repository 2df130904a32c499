#!/usr/bin/env bash
# Depth-only perception (issue 50) on the GPU machine: the reference tables, the oracle and
# protocol ablations, and the studies that rest on the method's perception. MuJoCo goes along as
# wheels (../shared/gpu/README.md); each step writes $OUT/NAME.tar.gz (attempts gzipped) and its
# log, and prints its exit code, time and summary line. Steps (several per call):
#   tables-PRESET     Tables 1+2, 1,000 trials per cell: the reference (PRESET: paper, realistic)
#   ablation-PRESET   Setups 2 and 3, 1,000 rounds, paired: perception.oracle x
#                     procedure.remove_failed (the oracle's value and the protocol's)
#   single-PRESET     Setup 1, a-f and g-l, 1,000 trials per object, paired: perception.oracle
#   sloped            the sloped Setup 1 variant (view_tilt_deg=30), a-f, 300 trials per object,
#                     paired: perception.oracle (paper preset)
#   methods-PRESET    the paper's method and the baselines on the same worlds, Tables 1+2,
#                     TRIALS (default 300) per cell, paired, one grid point per method
#   planes-sloped     perception only: first views of 1,000 sloped Setup 1 worlds per object,
#                     window x threshold (5 x 5 grid points)
#   planes-bin        the same on 4,096 Setup 3 rounds
#   studies           window and threshold, Table 1 protocol, realistic preset
#                     (experiments/studies.py window threshold)
#   improve-PRESET    a depth-only improvement against the default, Setups 2 and 3, 1,000
#                     rounds, paired: IMPROVE=KEY=V1,V2,... names the grid (results/depth_only/)
# Committed as: tables-* -> results/PRESET_gpu_1000; ablation, single, sloped, improve ->
# results/depth_only/; methods-PRESET (TRIALS=300) -> results/methods/PRESET_gpu_300;
# studies, planes-* -> results/studies/ (each folder's README says which commit made it).
set -uo pipefail
out=${OUT:?set OUT to the folder that collects the results}
trials=${TRIALS:-300}
gj() { python3 -m graspjax.cli "$@"; }
step() {  # step NAME ARGS...: one graspjax command into $out/NAME, then pack it
  local name=$1 start=$SECONDS
  shift
  gj "$@" --seed 0 --quiet --out "$out/$name" > "$out/$name.log" 2>&1
  echo "== $name: exit $? after $((SECONDS - start)) s; $(head -n 1 "$out/$name.log")"
  gzip -f "$out/$name/attempts.csv" "$out/$name/planes.csv" 2>/dev/null
  rm -f "$out/$name/attempts.parquet"
  tar -C "$out" -czf "$out/$name.tar.gz" "$name" && rm -rf "${out:?}/$name"
}
oracle=perception.oracle=false,true
windows=align.window_px=5,10,15,20,30
thresholds=align.distance_threshold=0.05,0.1,0.3,0.6,1.0
for name in "$@"; do
  preset=${name#*-}
  case "$name" in
    tables-*) step "${preset}_gpu_1000" run --table 1,2 --trials 1000 --preset "$preset" ;;
    ablation-*) step "ablation_$preset" sweep --setup 2,3 --trials 1000 --paired --preset "$preset" \
      --grid "$oracle" --grid procedure.remove_failed=true,false ;;
    single-*)
      step "single_abcdef_$preset" sweep --setup 1 --objects abcdef --trials 1000 --paired \
        --preset "$preset" --grid "$oracle"
      step "single_ghijkl_$preset" sweep --setup 1 --objects ghijkl --trials 1000 --paired \
        --preset "$preset" --grid "$oracle" ;;
    sloped) step sloped sweep --setup 1 --objects abcdef --trials 300 --paired \
      --set procedure.view_tilt_deg=30 --grid "$oracle" ;;
    methods-*) step "methods_$preset" sweep --table 1,2 --trials "$trials" --paired --preset "$preset" \
      --grid method=paper,highest-pca,antipodal ;;
    planes-sloped) step planes_sloped planes --setup 1 --objects abcdef --trials 1000 \
      --set procedure.view_tilt_deg=30 --grid "$windows" --grid "$thresholds" ;;
    planes-bin) step planes_bin planes --setup 3 --objects abcdef --trials 4096 --set layout.bin=true \
      --grid "$windows" --grid "$thresholds" ;;
    studies)
      start=$SECONDS
      OUT="$out/studies" python3 experiments/studies.py window threshold > "$out/studies.log" 2>&1
      echo "== studies: exit $? after $((SECONDS - start)) s"
      for s in window threshold; do gzip -f "$out/studies/$s/attempts.csv"; rm -f "$out/studies/$s/attempts.parquet"; done
      tar -C "$out" -czf "$out/studies.tar.gz" studies && rm -rf "${out:?}/studies" ;;
    improve-*) step "improve_$preset" sweep --setup 2,3 --trials 1000 --paired --preset "$preset" \
      --grid "${IMPROVE:?set IMPROVE to the --grid of the improvement}" ;;
    *) echo "unknown step $name" >&2; exit 2 ;;
  esac
done
