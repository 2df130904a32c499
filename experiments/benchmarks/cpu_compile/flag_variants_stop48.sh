. .venv/bin/activate  # from the repository root
G=${1:-0}
Y="--xla_cpu_experimental_ynn_fusion_type="
run() { name=$1; shift; /usr/bin/time -f "  user %U s sys %S s wall %e s" env XLA_FLAGS="$Y $*" python experiments/benchmarks/cpu_compile/flag_variants_stop48.py $G $name 2>&1 | grep -v -i warn; }
run base
run fast_compile --xla_cpu_opt_preset=CPU_OPT_PRESET_FAST_COMPILE
run no_expensive --xla_llvm_disable_expensive_passes=true
run no_unroll --xla_cpu_disable_loop_unrolling=true
run no_slp --xla_cpu_disable_slp_vectorizer=true
run base_again
run() { name=$1; shift; /usr/bin/time -f "  user %U s sys %S s wall %e s" env XLA_FLAGS="$Y $*" python experiments/benchmarks/cpu_compile/flag_variants_stop48.py $G $name 2>&1 | grep -v -i "warn" | tail -3; }
# second script (same helpers):
run opt0 --xla_backend_optimization_level=0
run fastisel --xla_backend_extra_options=-fast-isel=true
run novec --xla_backend_extra_options=-vectorize-loops=false,-vectorize-slp=false
run base_again2
