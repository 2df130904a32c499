#!/usr/bin/env bash
# The paper's parameter studies on the method the paper preset runs (results/studies/): every
# grid point plays the same worlds (--paired), Tables 1+2 (a-f in Setups 1-3, g-l in Setup 1),
# TRIALS per cell (default 300); each folder's sweep_KEY.csv/png give first view and rescued
# per setup, and against the paper's value the objects gained and lost, McNemar's z and p and
# the smallest difference the pairs resolve (`graspjax report`). DEVICE=gpu (one GPU; MuJoCo as wheels,
# ../shared/gpu/README.md) packs each folder into $OUT/NAME.tgz; DEVICE=cpu writes results/studies.
#   window           align.window_px 5-30 (the paper: 15)
#   threshold        align.distance_threshold 0.05-1.0 (the paper: 0.3)
#   realign          procedure.max_reorientations 0-3 (the paper: 1)
#   readings         the triangles' anchor and the turn: the paper's reading and ours, one at a
#                    time and together (static: one program per point)
#   triangles        our readings where the paper gives no number: the triangles' corners B, C
#                    3 / 5 / 8 px from A, a plane's minimum inliers 3 / 10 / 20
#   tolerance        the T-beam's antipodal-edge tolerance 15 / 25 / 35 deg (the paper gives none)
#   cone             the T-beam against the antipodal sampler at equal angles: the T-beam's edge
#                    tolerance and the sampler's cone 15 and 35 deg each (each method its own
#                    programs)
#   sloped-NAME      NAME with every view tilted 30 deg off vertical (procedure.view_tilt_deg=30),
#                    where the re-alignment is needed
#   planes           `graspjax planes`: the winning plane's normal error and view tilt over
#                    window x threshold, Setups 1-3, flat and sloped (perception only)
# JOBS (default "--table 1,2") and TAG (default none; appended to each folder's name) run a
# study on part of the tables, e.g. JOBS="--setup 3 --objects a,b,c,d,e,f" TAG=_setup3.
# The studies of align.* and the re-alignments (window, threshold, realign, readings, triangles)
# reuse a plain run of their worlds (`graspjax sweep --reuse`: only the worlds where a view held
# no grasp play again at each point), made once per variant into RUNS (default a folder under
# /tmp, never results/) and kept there for the next study of the same worlds.
set -uo pipefail
device=${DEVICE:-cpu}
trials=${TRIALS:-300}
read -r -a jobs <<< "${JOBS:---table 1,2}"
tag=${TAG:-}
runs=${RUNS:-/tmp/graspjax_study_runs}
case "$device" in
  cpu) out=${OUT:-results/studies} ;;
  gpu) out=${OUT:?set OUT to the folder that collects the results} ;;
  *) echo "DEVICE must be cpu or gpu" >&2; exit 2 ;;
esac
step() {  # step FOLDER COMMAND ARGS...: one graspjax command into $out/FOLDER
  local folder=$out/$1 start=$SECONDS
  shift
  mkdir -p "$out"
  python3 -m graspjax.cli "$@" --seed 0 --quiet --overwrite --out "$folder" > "$folder.log" 2>&1
  local code=$?
  echo "== $folder: exit $code after $((SECONDS - start)) s"
  tail -n 2 "$folder.log"
  if [ "$code" -ne 0 ]; then return "$code"; fi
  if [ -f "$folder/attempts.csv" ]; then  # the rows as compact Parquet, less what the study
    # never reads (report.files.keep_attempts, schema.STUDY_OMITS)
    python3 -c "import sys; from graspjax.report.files import keep_attempts; from graspjax.schema import STUDY_OMITS; keep_attempts(sys.argv[1], STUDY_OMITS)" \
      "$folder"
  fi
  gzip -f "$folder/rounds.csv" "$folder/planes.csv" 2>/dev/null
  rm -f "$folder.log"
  if [ "$device" = gpu ]; then
    tar -C "$out" -czf "$out/$(basename "$folder").tgz" "$(basename "$folder")" && rm -rf "$folder"
  fi
}
reused() {  # reused STUDY [--set ...]: the --reuse argument of a study over align.* or the
  # re-alignments (the plain run of its worlds, made here once), else nothing
  case "$1" in window|threshold|realign|readings|triangles) ;; *) return 0 ;; esac
  shift
  local folder=$runs/run${tag}_${device}_$trials${1:+_sloped}
  if ! grep -qs '"finished"' "$folder/config.json"; then
    mkdir -p "$runs"
    python3 -m graspjax.cli run "${jobs[@]}" --trials "$trials" --preset paper "$@" --seed 0 \
      --quiet --overwrite --out "$folder" > "$folder.log" 2>&1 || { tail -n 2 "$folder.log" >&2; return 1; }
    rm -f "$folder.log"
  fi
  echo "--reuse $folder"
}
grid() {  # the --grid argument of one study
  case "$1" in
    window) echo "align.window_px=5,10,15,20,25,30" ;;
    threshold) echo "align.distance_threshold=0.05,0.1,0.2,0.3,0.5,1.0" ;;
    realign) echo "procedure.max_reorientations=0,1,2,3" ;;
    readings) echo "align.anchor:align.window_centre:align.turn_normal=\
nearest:anchor:pixel,centre:anchor:pixel,nearest:triangle:pixel,nearest:anchor:metric,\
centre:triangle:metric" ;;
    triangles) echo "align.triangle_radius_px:align.min_inliers=5:10,3:10,8:10,5:3,5:20" ;;
    tolerance) echo "detect.antipodal_tolerance_deg=15,25,35" ;;
    cone) echo "method:detect.antipodal_tolerance_deg:baseline.antipodal_cone_deg=\
paper:15:35,paper:35:35,antipodal:35:15,antipodal:35:35" ;;
    *) echo "unknown study $1" >&2; return 2 ;;
  esac
}
for name in "$@"; do
  case "$name" in
    planes) step "planes_${device}_$trials" planes --setup 1,2,3 --trials "$trials" --preset paper \
      --grid align.window_px=5,10,15,20,25,30 --grid align.distance_threshold=0.05,0.1,0.2,0.3,0.5,1.0
      step "planes_sloped_${device}_$trials" planes --setup 1,2,3 --trials "$trials" \
      --preset paper --set procedure.view_tilt_deg=30 --grid align.window_px=5,10,15,20,25,30 \
      --grid align.distance_threshold=0.05,0.1,0.2,0.3,0.5,1.0 ;;
    sloped-*) g=$(grid "${name#sloped-}") || exit 2
      r=$(reused "${name#sloped-}" --set procedure.view_tilt_deg=30) || exit 1
      read -r -a r <<< "$r"
      step "${name#sloped-}_sloped${tag}_${device}_$trials" sweep "${jobs[@]}" --trials "$trials" \
      --paired --preset paper --set procedure.view_tilt_deg=30 --grid "$g" "${r[@]}" ;;
    *) g=$(grid "$name") || exit 2
      r=$(reused "$name") || exit 1
      read -r -a r <<< "$r"
      step "${name}${tag}_${device}_$trials" sweep "${jobs[@]}" --trials "$trials" --paired \
      --preset paper --grid "$g" "${r[@]}" ;;
  esac
done
