set -u
run() { # name, extra args
  c=$(mktemp -d); s=$(date +%s.%N)
  GRASPJAX_CACHE=$c python3 -m graspjax.cli run --setup 1 --objects b --trials 3000 --seed 0 --quiet --out $OUT/$1 "${@:2}" > $OUT/$1.log 2>&1
  echo "$1 rc=$? total $(python3 -c "print(round($(date +%s.%N)-$s,1))") s" | tee -a $OUT/totals.txt
  rm -rf $c $OUT/$1/attempts.parquet $OUT/$1/*.png
}
run ms4
run ms2 --set sim.timestep=0.002 --set sim.segment_steps=50
run ms5 --set sim.timestep=0.005 --set sim.segment_steps=20
for v in ms2 ms5; do echo "== ms4 -> $v"; python3 experiments/paired_rows.py $OUT/ms4/attempts.csv $OUT/$v/attempts.csv 2>&1 | tail -4; done | tee $OUT/paired.txt
python3 - <<'PY'
import os, pandas as pd
out = os.environ["OUT"]
for v in ["ms4", "ms2", "ms5"]:
    a = pd.read_csv(f"{out}/{v}/attempts.csv")
    print(v, len(a), a.outcome.value_counts().to_dict())
PY
cd $OUT && tar czf all.tgz ms4 ms2 ms5 *.log *.txt && rm -rf ms4 ms2 ms5
