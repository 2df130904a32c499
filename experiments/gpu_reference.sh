#!/usr/bin/env bash
# The GPU reference measurements, in a few long calls on the GPU machine (see ../shared/gpu/README.md:
# MuJoCo goes along as wheels; the package runs from the source tree on PYTHONPATH).
#   experiments/gpu_reference.sh runner      # runner before/after (OLD=a tree holding the old package),
#                                            #   deterministic vs --fast
#   experiments/gpu_reference.sh cold        # Tables 1+2 at 1,000 trials, cold compiles
#   experiments/gpu_reference.sh repro       # the same command in several processes (bit-identical?),
#                                            #   another --batch
#   experiments/gpu_reference.sh detect      # graspjax detect on 640x480 images, batched
#   experiments/gpu_reference.sh tables      # Tables 1 and 2 at 1,000 trials per cell, both presets
#   (the parameter studies: experiments/studies.sh)
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
    grep -h -E "attempts/s|compile" "$out"/before.log "$out"/after.log "$out"/after_fast.log ;;
  cold)  # Tables 1+2 at 1,000 trials per cell, compiles included
    step tables env GRASPJAX_CACHE=0 python3 -m graspjax.cli run --table 1,2 --trials 1000 \
      --seed 0 --quiet --out "$out/tables"
    cat "$out/tables/timings.csv"
    pack runner_tables tables ;;
  detect)
    step detect gj bench detect --width 640 --height 480 --batch 1024 --repeats 10 \
      --out "$out/detect_gpu_h100.json"
    step detect_2048 gj bench detect --width 640 --height 480 --batch 2048 --repeats 10 \
      --out "$out/detect_gpu_h100_2048.json" ;;
  repro)  # the same command in separate processes: compiled fresh, from the compilation cache,
    # fresh again; then another --batch
    job=(run --setup 1 --objects abcdef --preset realistic --trials 200 --seed 1 --quiet)
    step fresh_a env GRASPJAX_CACHE="$out/cache" python3 -m graspjax.cli "${job[@]}" --out "$out/fresh_a"
    step cached env GRASPJAX_CACHE="$out/cache" python3 -m graspjax.cli "${job[@]}" --out "$out/cached"
    step fresh_b env GRASPJAX_CACHE=0 python3 -m graspjax.cli "${job[@]}" --out "$out/fresh_b"
    step batch_600 env GRASPJAX_CACHE="$out/cache" python3 -m graspjax.cli "${job[@]}" --batch 600 \
      --out "$out/batch_600"
    rm -rf "$out/cache"
    python3 - "$out" <<'EOF'
import sys, pandas as pd
out = sys.argv[1]
runs = {n: pd.read_csv(f"{out}/{n}/attempts.csv")
        for n in ("fresh_a", "cached", "fresh_b", "batch_600")}
for a, b in [("fresh_a", "cached"), ("fresh_a", "fresh_b"), ("fresh_a", "batch_600")]:
    x, y = runs[a].drop(columns="chunk"), runs[b].drop(columns="chunk")
    same = x.shape == y.shape and x.equals(y)
    rows = "-" if x.shape != y.shape else int((x.ne(y) & ~(x.isna() & y.isna())).any(axis=1).sum())
    print(f"{a} vs {b}: {'identical' if same else 'DIFFER'} ({rows} of {len(x)} rows differ)")
for n, f in runs.items():
    print(n, f"success {f.success.mean():.3f} of {len(f)}")
EOF
    pack repro fresh_a fresh_b batch_600 && rm -rf "$out/cached" ;;
  tables)
    step tables env OUT="$out" bash experiments/paper_tables.sh gpu
    for preset in paper realistic; do cat "$out/${preset}_gpu_1000/timings.csv"; done
    pack tables paper_gpu_1000 realistic_gpu_1000 ;;
  bench)
    step physics_paper gj bench physics --objects abcdef --setup 3 --batch 8192 \
      --out "$out/physics_gpu_h100_bin_8192.json"
    step physics_kinect gj bench physics --objects abcdef --setup 3 --batch 8192 --preset realistic \
      --out "$out/physics_gpu_h100_bin_8192_kinect.json"
    step perception gj bench perception --batch 4096 --repeats 10 \
      --out "$out/perception_gpu_h100_4096.json"
    grep -h -E "world-steps/s|images/s" "$out"/physics_paper.log "$out"/physics_kinect.log \
      "$out"/perception.log ;;
  multigpu)  # the same job on one GPU and on every GPU, 3,000 worlds per GPU per call: the
    # same device slices, so the rows must agree; throughput from timings.csv (compiles apart)
    job=(run --setup 1 --objects abcdef --trials 2000 --seed 0 --quiet)
    step one_gpu env CUDA_VISIBLE_DEVICES=0 python3 -m graspjax.cli "${job[@]}" --batch 3000 \
      --out "$out/one_gpu"
    step all_gpus gj "${job[@]}" --batch 6000 --out "$out/all_gpus"
    python3 - "$out" <<'EOF'
import json, sys, pandas as pd
out = sys.argv[1]
rates = {}
for name in ("one_gpu", "all_gpus"):
    t = pd.read_csv(f"{out}/{name}/timings.csv")
    devices = json.load(open(f"{out}/{name}/config.json"))["devices"]
    rates[name] = t.attempts.sum() / t.wall_s.sum()
    print(f"{name}: {len(devices)} device(s), compile {t.compile_s.max():.1f} s, "
          f"run {t.wall_s.sum():.1f} s = {rates[name]:.1f} attempts/s")
a, b = (pd.read_csv(f"{out}/{n}/attempts.csv").drop(columns="chunk") for n in ("one_gpu", "all_gpus"))
print("rows:", "identical" if a.equals(b) else "DIFFER", f"({len(a)} attempts)")
print(f"speed-up: {rates['all_gpus'] / rates['one_gpu']:.2f}x")
EOF
    for name in one_gpu all_gpus; do cp "$out/$name/timings.csv" "$out/${name}_timings.csv"; done
    rm -rf "$out/one_gpu" "$out/all_gpus" ;;
  *) echo "usage: $0 runner|cold|repro|detect|tables|bench|multigpu" >&2; exit 2 ;;
esac
