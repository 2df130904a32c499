"""Compile, beside the suite, the physics program its late tests would otherwise compile first.

conftest starts this in a second process when the session starts. It builds the a-f scene's
physics program as `test_procedure._world` does and leaves it in the persistent compilation
cache while the suite's first modules leave a core idle; `test_physics`, its first user, then
loads it (about 45 s of compile on the 2-core machine; a cold suite took 877 s with this, 892 and
903 s without). Warming more programs here (the g-l scene, `select_target`) did not help: the
tests missed them in the cache. Why is not established: the a-f program lowered twice in one
process, with `jax.clear_caches` and another scene between, gives identical text, so the
misses may be programs that differ, not one program with two keys. It checks nothing: a
failure here only costs the tests their own compile.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from conftest import Worlds  # noqa: E402  (also sets the cache and XLA_FLAGS)


def main() -> None:
    import test_procedure

    from graspjax.config import Config
    from graspjax.sim import scene_for

    basic = Worlds(scene_for(tuple("abcdef"), Config(), True))
    test_procedure._world(basic, {0: (-0.06, 0.0, 0.0)})  # reset, settle, kinematics


if __name__ == "__main__":
    main()
