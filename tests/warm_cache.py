"""Compile, beside the suite, the physics program its late tests would otherwise compile first.

conftest starts this in a second process when the session starts. It builds the a-f scene's
physics program as `conftest.Worlds` does and leaves it in the persistent compilation cache
while the suite's first modules leave a core idle; `test_physics`, its first user, then loads
it (about 45 s of compile on the 2-core machine).

Only this program is warmed, because only it is known to hit. A program's cache key hashes its
lowered text, and that text depends on what the process traced before: JAX lowers each nested
jitted function (`jnp.where`, `jnp.remainder`, ...) once per distinct traced jaxpr, and whether
two calls share one depends on its trace caches. The g-l program lowered here and in
`test_physics` after the a-f tests differ only that way (531 against 538 private functions,
the same computation), so it missed. It checks nothing: a failure here only costs the test its
own compile.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from conftest import SIM_BATCH, Worlds  # noqa: E402  (also sets the cache and XLA_FLAGS)


def main() -> None:
    import numpy as np

    from graspjax.config import Config
    from graspjax.sim import scene_for

    sim = Worlds(scene_for(tuple("abcdef"), Config(), True))
    n = sim.scene.num_objects
    pos = np.zeros((SIM_BATCH, n, 3))
    quat = np.tile([1.0, 0.0, 0.0, 0.0], (SIM_BATCH, n, 1))
    sim.settle(sim.reset(pos, quat, np.zeros((SIM_BATCH, n), bool)), 0.1)


if __name__ == "__main__":
    main()
