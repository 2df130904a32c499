#!/usr/bin/env bash
# The GPU reference measurements, in a few long calls on the GPU machine (see ../shared/gpu/README.md:
# MuJoCo goes along as wheels; the package runs from the source tree on PYTHONPATH).
#   experiments/gpu_reference.sh runner      # runner before/after (OLD=a tree holding the old package),
#                                            #   deterministic vs --fast, Tables 1+2 at 1,000 trials with
#                                            #   cold compiles
#   experiments/gpu_reference.sh repro       # the same command twice (bit-identical?), another --batch
#   experiments/gpu_reference.sh detect      # graspjax detect on 640x480 images, batched
#   experiments/gpu_reference.sh tables      # Tables 1 and 2 at 1,000 trials per cell, both presets
#   experiments/gpu_reference.sh studies     # the traced studies (experiments/studies.sh traced),
#                                            #   the same command twice, the bin's physics with a Kinect
#   experiments/gpu_reference.sh bench       # the bin scene's physics, Kinect rendering, perception
#   experiments/gpu_reference.sh multigpu    # one GPU against all GPUs of the host, same job
# Every step writes into $OUT (a log per step; run folders packed into tarballs, since the machine
# returns at most 8 files) and prints a short summary last.
set -uo pipefail
out=${OUT:?set OUT to the folder that collects the results}
gj() { python3 -m graspjax.cli "$@"; }
step() {  # step NAME COMMAND...: run, log to $out/NAME.log, show the tail and the time taken
  local name=$1 start=$SECONDS
  shift
  echo "== $name: $*"
  "$@" > "$out/$name.log" 2>&1
  local rc=$?
  tail -n 6 "$out/$name.log"
  echo "== $name: exit $rc after $((SECONDS - start)) s"
}
pack() {  # pack FOLDER...: one tarball for the folders (the machine returns at most 8 files)
  local name=$1
  shift
  tar -C "$out" -czf "$out/$name.tar.gz" "$@" && (cd "$out" && rm -rf "$@")
}
case "${1:-}" in
  runner)
    if [ -n "${OLD:-}" ]; then  # from the old tree itself: python -m puts the working directory first
      step before bash -c "cd '$OLD' && python3 -m graspjax.cli bench pipeline --objects abcdef \
        --setup 1 --trials 1000"
    fi
    step after gj bench pipeline --objects abcdef --setup 1 --trials 1000 --out "$out/after.json"
    step after_fast gj bench pipeline --objects abcdef --setup 1 --trials 1000 --fast \
      --out "$out/after_fast.json"
    step tables env GRASPJAX_CACHE=0 python3 -m graspjax.cli run --table 1,2 --trials 1000 \
      --seed 0 --quiet --out "$out/tables"
    cat "$out/tables/timings.csv"
    pack runner_tables tables
    grep -h -E "attempts/s|compile" "$out"/before.log "$out"/after.log "$out"/after_fast.log ;;
  detect)
    step detect gj bench detect --width 640 --height 480 --batch 1024 --repeats 10 \
      --out "$out/detect_gpu_h100.json"
    step detect_2048 gj bench detect --width 640 --height 480 --batch 2048 --repeats 10 \
      --out "$out/detect_gpu_h100_2048.json" ;;
  repro)
    step twice_a gj run --table 1 --trials 1000 --seed 1 --quiet --out "$out/twice_a"
    step twice_b gj run --table 1 --trials 1000 --seed 1 --quiet --out "$out/twice_b"
    step batch_1000 gj run --table 1 --trials 1000 --seed 1 --batch 1000 --quiet \
      --out "$out/batch_1000"
    if cmp -s "$out/twice_a/attempts.csv" "$out/twice_b/attempts.csv"; then
      echo "same command twice: attempts.csv identical"
    else
      echo "same command twice: attempts.csv DIFFERS"
    fi
    python3 - "$out" <<'EOF'
import sys, pandas as pd
for name in ("twice_a", "batch_1000"):
    f = pd.read_csv(f"{sys.argv[1]}/{name}/summary.csv")
    print(name, f.groupby("setup")[["successes", "n"]].sum().to_dict("index"))
EOF
    pack repro twice_a batch_1000 && rm -rf "$out/twice_b" ;;
  tables)
    step tables env OUT="$out" bash experiments/paper_tables.sh gpu
    for preset in paper realistic; do cat "$out/${preset}_gpu_1000/timings.csv"; done
    pack tables paper_gpu_1000 realistic_gpu_1000 ;;
  studies)  # the traced studies (one set of compiled programs), reproducibility, the bin's physics
    step studies env OUT="$out" bash experiments/studies.sh traced
    step window_again gj sweep --table 1 --preset realistic --trials 100 --seed 0 --quiet \
      --grid align.window_px=5,10,15,20,25,30 --out "$out/window_again"
    if cmp -s "$out/window/attempts.csv" "$out/window_again/attempts.csv"; then
      echo "same command twice: attempts.csv identical"
    else
      echo "same command twice: attempts.csv DIFFERS"
    fi
    rm -rf "$out/window_again"
    step physics_kinect gj bench physics --objects abcdef --setup 3 --batch 8192 --preset realistic \
      --out "$out/physics_gpu_h100_bin_8192_kinect.json"
    grep -h -E "world-steps/s|images/s" "$out"/physics_kinect.log
    pack studies window threshold reorientations friction noise execution centring ;;
  bench)
    step physics_paper gj bench physics --objects abcdef --setup 3 --batch 8192 \
      --out "$out/physics_gpu_h100_bin_8192.json"
    step physics_kinect gj bench physics --objects abcdef --setup 3 --batch 8192 --preset realistic \
      --out "$out/physics_gpu_h100_bin_8192_kinect.json"
    step perception gj bench perception --batch 4096 --repeats 10 \
      --out "$out/perception_gpu_h100_4096.json"
    grep -h -E "world-steps/s|images/s" "$out"/physics_paper.log "$out"/physics_kinect.log \
      "$out"/perception.log ;;
  multigpu)  # the same job on one GPU and on every GPU, 3,000 worlds per GPU per call
    step one_gpu env CUDA_VISIBLE_DEVICES=0 python3 -m graspjax.cli bench pipeline \
      --objects abcdef --setup 1 --trials 2000 --batch 3000 --out "$out/one_gpu.json"
    step all_gpus gj bench pipeline --objects abcdef --setup 1 --trials 2000 --batch 6000 \
      --out "$out/all_gpus.json"
    grep -h -E "device|attempts/s" "$out"/one_gpu.log "$out"/all_gpus.log ;;
  *) echo "usage: $0 runner|repro|detect|tables|studies|bench|multigpu" >&2; exit 2 ;;
esac
