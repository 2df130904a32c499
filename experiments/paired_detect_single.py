"""`graspjax detect`'s single-image latency, a git revision against the working tree, in one process.

    python3 experiments/paired_detect_single.py REVISION [TOP_K] [ROUNDS]

Separate processes on a shared 2-core machine differ by more than most changes (once: the
same code 15.5 and 17.6 ms in two processes). Here both versions are compiled in one process
(REVISION's `graspjax/` exported by `git archive` and imported as `graspjax_rev`), and each of
`graspjax bench detect`'s 64 scenes goes through both, in alternating order, ROUNDS times (3),
top K = TOP_K (5). Prints whether every output array is identical (else which fields differ,
on how many scenes), each side's median and the paired median difference. Run from the
repository root; nothing is written.
"""

import collections
import dataclasses
import importlib
import re
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import jax
import numpy as np

from graspjax.bench import detect_workload
from graspjax.config import Config, RealImageConfig
from graspjax.perception.real_image import detect_real_image


def import_revision(revision: str, folder: Path):
    """REVISION's `graspjax` package as `graspjax_rev` (its imports renamed): its
    `perception.real_image`, `config` and `camera` modules. Fails if importing it loaded a
    module of the working tree's `graspjax` (an import the renaming missed)."""
    archive = subprocess.run(["git", "archive", revision, "graspjax"], check=True,
                             capture_output=True).stdout
    subprocess.run(["tar", "-x", "-C", str(folder)], input=archive, check=True)
    package = folder / "graspjax_rev"
    (folder / "graspjax").rename(package)
    for path in package.rglob("*.py"):
        path.write_text(re.sub(r"\bgraspjax\b", "graspjax_rev", path.read_text()))
    sys.path.insert(0, str(folder))
    loaded = {name for name in sys.modules if name.split(".")[0] == "graspjax"}
    modules = [importlib.import_module(f"graspjax_rev.{name}")
               for name in ("perception.real_image", "config", "camera")]
    added = {name for name in sys.modules if name.split(".")[0] == "graspjax"} - loaded
    if added:
        raise RuntimeError(f"{revision} imported the working tree's {sorted(added)}")
    return modules


def differing(first, second) -> set[str]:
    """The fields (by name) of two results whose arrays differ, nan where nan equal."""
    paths = [jax.tree_util.tree_flatten_with_path(result)[0] for result in (first, second)]
    names = [[jax.tree_util.keystr(path) for path, _ in leaves] for leaves in paths]
    if names[0] != names[1]:
        return set(names[0]) ^ set(names[1])
    return {name for name, (_, a), (_, b) in zip(names[0], *paths, strict=True)
            if not np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True)}


def main() -> None:
    if len(sys.argv) < 2:
        sys.exit(__doc__)
    revision = sys.argv[1]
    top = int(sys.argv[2]) if len(sys.argv) > 2 else 5
    rounds = int(sys.argv[3]) if len(sys.argv) > 3 else 3
    camera, workspace, scenes = detect_workload(640, 480)
    image = dataclasses.replace(RealImageConfig(), top_k=top)
    with tempfile.TemporaryDirectory() as folder:
        old_module, old_config, old_camera = import_revision(revision, Path(folder))
        old_image = old_config.RealImageConfig(**{f.name: getattr(image, f.name)
                                                  for f in dataclasses.fields(old_config.RealImageConfig)})
        runs = {}
        for name, detect, cam, config, settings in (
                (revision, old_module.detect_real_image,
                 old_camera.Camera(camera.width, camera.height, camera.fx, camera.fy, camera.cx,
                                   camera.cy), old_config.Config(), old_image),
                ("working tree", detect_real_image, camera, Config(), image)):
            compiled = jax.jit(detect)
            runs[name] = (lambda f, k, c, s: lambda depth: f(depth, workspace, k, c, s))(
                compiled, cam, config, settings)
            start = time.perf_counter()
            jax.block_until_ready(runs[name](scenes[0]))
            print(f"{name}: compiled in {time.perf_counter() - start:.1f} s", flush=True)
        names = list(runs)
        differ = collections.Counter(name for depth in scenes
                                     for name in differing(*(runs[n](depth) for n in names)))
        times = {name: [] for name in names}
        for r in range(rounds):
            for i, depth in enumerate(scenes):
                for name in (names if (i + r) % 2 else names[::-1]):
                    start = time.perf_counter()
                    jax.block_until_ready(runs[name](depth))
                    times[name].append(time.perf_counter() - start)
    print(f"{jax.devices()[0].device_kind}, top {top}, {len(scenes)} scenes x {rounds}; "
          f"every output identical: {not differ}")
    for field, count in sorted(differ.items()):
        print(f"  {field} differs on {count} scenes")
    for name, seconds in times.items():
        print(f"{name:>14}: median {1e3 * statistics.median(seconds):6.2f} ms, "
              f"p90 {1e3 * np.percentile(seconds, 90):6.2f} ms")
    difference = np.subtract(*(times[n] for n in names))
    print(f"paired ({names[0]} - {names[1]}): median {1e3 * np.median(difference):.2f} ms")


if __name__ == "__main__":
    main()
