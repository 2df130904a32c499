#!/usr/bin/env bash
# Setup 3's bin variant (layout.bin), its two unknowns (issue 16): the bin floor against the
# objects' footprint and the gripper's size, on the GPU machine (MuJoCo as wheels: ../shared/gpu/README.md). The paper
# gives neither; no value is picked to match its 58 %. Each bin size and gripper is its own
# scene (static), so each grid point compiles its own program; two calls of four points each:
#   experiments/bin_gripper_gpu.sh small   # bins 0.16, 0.18, 0.22, 0.26 m, gripper 6 cm / 1 cm
#   experiments/bin_gripper_gpu.sh franka  # the same bins, the Franka hand (8 cm / 2 cm, default)
# The a-f objects' total footprint is 0.0167 m^2: the bins' floors are 1.5, 1.9, 2.9 and 4.0
# times it. Setup 3, 200 rounds (1,200 attempts) per point, paired (the same seeds per bin).
set -uo pipefail
out=${OUT:?set OUT to the folder that collects the results}
case "${1:-}" in
  small) hand=gripper.opening:gripper.finger_width:gripper.finger_thickness=0.06:0.01:0.006 ;;
  franka) hand=gripper.opening:gripper.finger_width:gripper.finger_thickness=0.08:0.02:0.012 ;;
  *) echo "usage: $0 small|franka" >&2; exit 2 ;;
esac
start=$SECONDS
python3 -m graspjax.cli sweep --setup 3 --trials 200 --seed 0 --paired --quiet --set layout.bin=true \
  --grid layout.bin_size=0.16,0.18,0.22,0.26 --grid "$hand" --out "$out/bin_$1" \
  > "$out/bin_$1.log" 2>&1
echo "== bin_$1: exit $? after $((SECONDS - start)) s"; tail -n 2 "$out/bin_$1.log"
tar -C "$out" -czf "$out/bin_$1.tar.gz" "bin_$1" && rm -rf "${out:?}/bin_$1"
