#!/usr/bin/env bash
# The grasp methods on the same worlds (issue 20): Tables 1 and 2 at 1,000 trials per cell, every
# method paired (the same layouts and keys), each with the paper's re-alignment; and Setup 3
# rounds continued until the pile is cleared or stuck.
#   OUT=... experiments/methods_gpu.sh paper        # -> $OUT/methods_paper.tar.gz
#   OUT=... experiments/methods_gpu.sh realistic    # -> $OUT/methods_realistic.tar.gz
#   OUT=... experiments/methods_gpu.sh clutter      # -> $OUT/clutter.tar.gz
#   OUT=... experiments/methods_gpu.sh tbeams paper # three T-beams per edge (the paper's proposed
#                                                   # extension), the same worlds as the sweep's
#                                                   # paper point; WARM=1 runs it twice (the second
#                                                   # loads the exported programs: warm timings)
# (on the GPU machine: ../shared/gpu/README.md; TRIALS=... for another size)
set -uo pipefail
out=${OUT:?set OUT to the folder that collects the results}
trials=${TRIALS:-1000}
grid=method=paper,highest-pca,antipodal  # one point per method: the same chunks, the same
# settled world states (tests/test_experiment.py); each with the paper's re-alignment
run() {  # run NAME ARGS...: one graspjax command into $out/NAME, its log, a tarball of the folder.
  # It stops after LIMIT seconds (default 540, inside the machine's 10-minute call) and packs what
  # is done; RESUME=an earlier tarball of NAME continues that run (--resume) where it stopped.
  local name=$1 start=$SECONDS resume=()
  shift
  if [ -n "${RESUME:-}" ]; then tar -C "$out" -xzf "$RESUME" && resume=(--resume); fi
  timeout "${LIMIT:-540}" python3 -m graspjax.cli "$@" "${resume[@]}" --quiet --out "$out/$name" \
    > "$out/$name.log" 2>&1
  echo "== $name: exit $? after $((SECONDS - start)) s"
  tail -n 3 "$out/$name.log"
  cat "$out/$name/timings.csv" 2>/dev/null
  gzip -f "$out/$name/attempts.csv" 2>/dev/null
  tar -C "$out" -czf "$out/$name.tar.gz" "$name" && rm -rf "${out:?}/$name"
}
case "${1:-}" in
  paper|realistic)
    run "methods_$1" sweep --table 1,2 --trials "$trials" --seed 0 --paired --preset "$1" \
      --grid "$grid" ;;
  clutter)  # Setups 2 and 3, rounds of up to 12 attempts, paper and antipodal, paired
    run clutter sweep --setup 2,3 --trials "$trials" --seed 0 --paired \
      --set procedure.round_attempts=12 --grid method=paper,antipodal ;;
  tbeams)
    preset=${2:-paper}
    run "tbeams_$preset" run --table 1,2 --trials "$trials" --seed 0 --preset "$preset" \
      --set detect.tbeam_positions=3
    if [ -n "${WARM:-}" ]; then
      run "tbeams_${preset}_warm" run --table 1,2 --trials "$trials" --seed 0 --preset "$preset" \
        --set detect.tbeam_positions=3
    fi ;;
  *) echo "usage: $0 paper|realistic|clutter|tbeams PRESET" >&2; exit 2 ;;
esac
