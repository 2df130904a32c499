#!/usr/bin/env bash
# The departures of docs/departures.md that a setting switches, measured paired on the same worlds
# on the GPU machine (Tables 1+2, paper preset, TRIALS per cell, default 300); the reference
# tables, Eq. 2, Setup 3's sweeps and the methods are experiments/references.sh's. MuJoCo goes
# along as wheels (../shared/gpu/README.md); each step writes $OUT/NAME.tar.gz (attempts gzipped)
# and its log. Steps (several per call):
#   tolerance      the T-beam's antipodal-edge tolerance and the antipodal sampler's cone, 15 / 25 /
#                  35 deg each (results/studies/tolerance)
# (The alignment's readings and the triangles' size are studies of experiments/studies.sh.)
set -uo pipefail
out=${OUT:?set OUT to the folder that collects the results}
trials=${TRIALS:-300}
step() {  # step NAME COMMAND ARGS...: one graspjax command into $out/NAME, then pack it
  local name=$1 start=$SECONDS
  shift
  python3 -m graspjax.cli "$@" --seed 0 --quiet --out "$out/$name" > "$out/$name.log" 2>&1
  echo "== $name: exit $? after $((SECONDS - start)) s; $(tail -n 1 "$out/$name.log")"
  gzip -f "$out/$name/attempts.csv"
  rm -f "$out/$name/attempts.parquet"
  tar -C "$out" -czf "$out/$name.tar.gz" "$name" && rm -rf "${out:?}/$name"
}
paired() {  # paired NAME ARGS...: Tables 1+2, TRIALS per cell, paper preset, paired sweep
  local name=$1
  shift
  step "$name" sweep --table 1,2 --trials "$trials" --paired --preset paper "$@"
}
for name in "$@"; do
  case "$name" in
    tolerance) paired tolerance --grid "method:detect.antipodal_tolerance_deg:baseline.antipodal_cone_deg=\
paper:15:35,paper:25:35,paper:35:35,antipodal:15:15,antipodal:15:25,antipodal:15:35" ;;
    *) echo "unknown step $name" >&2; exit 2 ;;
  esac
done
