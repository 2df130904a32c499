"""Full step mid-grasp, box-box by MJX's collider vs the grid one, interleaved in one process."""
import os
import time

exec(open(os.path.join(os.path.dirname(__file__), "prep.py")).read())
from mujoco.mjx._src import collision_driver

owner = np.asarray(scene.geom_owner)
skip = scene.skips_far_pairs
def model_of(w, d): return with_parking(scene, physics_model(scene, w.config), d)
grid = dict(collision._GRID_PAIRS)
box = (collision._BOX, collision._BOX)
fns = {}
for name in ("mjx", "grid"):
    collision._GRID_PAIRS.clear(); collision._GRID_PAIRS.update(grid)
    if name == "mjx":
        collision._GRID_PAIRS[box] = collision_driver._COLLISION_FUNC[box]
    for part, fn in (("step", lambda d, w: collision.step_with(model_of(w, d), d, lambda m, d: collision.collision(m, d, owner, skip), solver.solve)),
                     ("collision", lambda d, w: collision.collision(model_of(w, d), d, owner, skip))):
        f = jax.jit(jax.vmap(fn, axis_name=WORLDS))
        t = time.perf_counter(); jax.block_until_ready(f(data, spec)); c = time.perf_counter() - t
        fns[(part, name)] = f
        print(f"compiled {part} {name} {c:.1f} s", flush=True)
res = {k: [] for k in fns}
for _ in range(10):
    for k, f in fns.items():
        for _ in range(5):
            t = time.perf_counter(); jax.block_until_ready(f(data, spec)); res[k].append(time.perf_counter() - t)
for k, v in res.items():
    print(f"{k[0]:10s} {k[1]:5s} {1e3*np.median(v):7.2f} ms", flush=True)
