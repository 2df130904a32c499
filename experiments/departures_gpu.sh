#!/usr/bin/env bash
# Where graspjax reads, fills in or changes the paper (issue 51; docs/departures.md): each
# departure that a setting switches, measured paired on the same worlds (Tables 1+2, paper
# preset, TRIALS per cell, default 300) on the GPU machine. MuJoCo goes along as wheels
# (../shared/gpu/README.md); each step writes $OUT/NAME.tar.gz (attempts gzipped) and its log.
#   tolerance   the T-beam's antipodal-edge tolerance and the antipodal sampler's cone, 15 / 25 /
#               35 deg each (results/studies/tolerance)
#   anchor      A at z_min ("nearest", the paper's Fig. 4) or at the centre of z_min's band (ours)
#   triangles   the triangles' radius (3 / 5 / 8 px) and the plane's minimum inliers (3 / 10 / 20)
#   window      the inlier window around A for every plane (the paper's words) or around each
#               triangle's centroid (ours)
#   turn        the tool turns by the plane's normal in the paper's pixel units or in metres (ours)
set -uo pipefail
out=${OUT:?set OUT to the folder that collects the results}
trials=${TRIALS:-300}
step() {  # step NAME ARGS...: one graspjax sweep into $out/NAME, then pack it
  local name=$1 start=$SECONDS
  shift
  python3 -m graspjax.cli sweep --table 1,2 --trials "$trials" --seed 0 --paired --preset paper \
    "$@" --quiet --out "$out/$name" > "$out/$name.log" 2>&1
  echo "== $name: exit $? after $((SECONDS - start)) s; $(tail -n 1 "$out/$name.log")"
  gzip -f "$out/$name/attempts.csv"
  rm -f "$out/$name/attempts.parquet"
  tar -C "$out" -czf "$out/$name.tar.gz" "$name" && rm -rf "${out:?}/$name"
}
for name in "$@"; do
  case "$name" in
    tolerance) step tolerance --grid "method:detect.antipodal_tolerance_deg:baseline.antipodal_cone_deg=\
paper:15:35,paper:25:35,paper:35:35,antipodal:15:15,antipodal:15:25,antipodal:15:35" ;;
    anchor) step anchor --grid align.anchor=nearest,centre ;;
    window) step window_centre --grid align.window_centre=anchor,triangle ;;
    turn) step turn_normal --grid align.turn_normal=pixel,metric ;;
    triangles) step triangles --grid "align.triangle_radius_px:align.min_inliers=5:10,3:10,8:10,5:3,5:20" ;;
    *) echo "unknown step $name" >&2; exit 2 ;;
  esac
done
