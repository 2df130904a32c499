"""Where a warm program load goes on the CPU (README's command's three programs, from a cache that
 README's command filled): lowering, cache key, file read, decompress, XLA's deserialization.

    GRASPJAX_CACHE=<that cache> python3 cpu_load_timing.py
"""
import os, sys, time, collections
t0 = time.perf_counter()
from graspjax import cli
os.environ["XLA_FLAGS"] = cli.with_xla_flags(os.environ.get("XLA_FLAGS", ""))
cli._compilation_cache()
import jax
from jax._src import compiler, compilation_cache
from graspjax.batch.plan import plan, table_job, default_batch, padded_size
from graspjax.batch.program import program
from graspjax.config import Config
print(f"imports {time.perf_counter()-t0:.2f}s", flush=True)
T = collections.defaultdict(float)
def timed(mod, name, label):
    f = getattr(mod, name)
    def g(*a, **k):
        s = time.perf_counter(); r = f(*a, **k); T[label] += time.perf_counter() - s; return r
    setattr(mod, name, g)
timed(compiler, "_resolve_compilation_strategy", "cache_key")
timed(compilation_cache, "decompress_executable", "decompress")
cache_get = compilation_cache._get_cache
def patched_get_cache(backend):
    c = cache_get(backend)
    if c is not None and not getattr(c, "_timed", False):
        timed(c, "get", "file_read"); c._timed = True
    return c
compilation_cache._get_cache = patched_get_cache
groups = plan([table_job(1, 10), table_job(2, 10)], [Config()], 0)
batch = int(sys.argv[1]) if len(sys.argv) > 1 else default_batch()
for g in groups:
    p = program(g, padded_size(len(g.worlds), batch), False)
    T.clear()
    s = time.perf_counter(); _ = p.portable; tp = time.perf_counter() - s
    s = time.perf_counter(); low = p.lower(0); tl = time.perf_counter() - s
    s = time.perf_counter(); c0 = low[0].compile(); c1 = low[1].compile(); tc = time.perf_counter() - s
    print(g.letters, g.collide, f"portable {tp:.2f} lower {tl:.2f} compile {tc:.2f}", dict((k, round(v, 2)) for k, v in T.items()), p.origin, flush=True)
    s = time.perf_counter()
    from jax.experimental import serialize_executable as se
    blob = se.serialize(c1)
    ts = time.perf_counter() - s
    s = time.perf_counter(); c1b = se.deserialize_and_load(*blob); td = time.perf_counter() - s
    print(f"   attempt exe serialized {len(blob[0])/1e6:.1f} MB in {ts:.2f}s, deserialize_and_load {td:.2f}s", flush=True)
