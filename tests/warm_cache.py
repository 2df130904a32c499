"""Compile, beside the suite, the physics program its late tests would otherwise compile first.

conftest starts this in a second process when the session starts. It builds the a-f scene's
physics program as `test_procedure._world` does (the first use of the `basic_sim` fixture in
`test_physics` and `test_procedure`) and leaves it in the persistent compilation cache while the
suite's first modules leave a core idle; those tests then load it (about 45 s of compile on the
2-core machine). The g-l scene and `select_target` were left out: built here, their programs
missed the tests' cache entries (not explained yet). It checks nothing: a failure here only
costs the tests their own compile.
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
