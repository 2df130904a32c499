set -u
c=$(mktemp -d); s=$(date +%s.%N)
GRASPJAX_CACHE=$c python3 -m graspjax.cli run --table 1,2 --trials 1000 --seed 0 --quiet --out $OUT/ms2 --set sim.timestep=0.002 --set sim.segment_steps=50 > $OUT/ms2.log 2>&1
echo "ms2 rc=$? total $(python3 -c "print(round($(date +%s.%N)-$s,1))") s" | tee -a $OUT/totals.txt
rm -rf $c $OUT/ms2/attempts.parquet $OUT/ms2/*.png
python3 experiments/paired_rows.py results/benchmarks/solver_iterations_h100_1000/it4/attempts.csv.gz $OUT/ms2/attempts.csv > $OUT/paired.txt 2>&1
cat $OUT/paired.txt $OUT/ms2/timings.csv
cd $OUT && tar czf all.tgz ms2 *.log *.txt && rm -rf ms2
