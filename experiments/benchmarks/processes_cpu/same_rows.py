"""Two attempts.csv files, column by column, all but run_id and chunk: `identical N rows` or what differs."""
import sys, pandas as pd, numpy as np
a = pd.read_csv(sys.argv[1]); b = pd.read_csv(sys.argv[2])
drop = [c for c in ("run_id", "chunk") if c in a.columns]
a = a.drop(columns=drop); b = b.drop(columns=[c for c in drop if c in b.columns])
assert list(a.columns) == list(b.columns), "columns differ"
if len(a) != len(b): print("rows", len(a), len(b)); sys.exit(1)
diff = 0
for c in a.columns:
    x, y = a[c].to_numpy(), b[c].to_numpy()
    if x.dtype.kind == "f": same = np.array_equal(x, y, equal_nan=True)
    else: same = np.array_equal(x.astype(str), y.astype(str))
    if not same: print("column differs:", c); diff += 1
print("identical" if diff == 0 else f"{diff} columns differ", len(a), "rows")
