"""Compile, beside the suite, the physics programs its late tests would otherwise compile first.

conftest starts this in a second process when the session starts. It builds the a-f and g-l
scenes' `conftest.Worlds`, whose physics programs compile ahead of time, and leaves them in
the persistent compilation cache while the suite's first modules leave a core idle;
`test_physics`, their first user, then loads them (about 45 s of compile each on the 2-core
machine).

A program's cache key hashes its lowered text, and that text depends on what the process
traced before: JAX lowers each nested jitted function (`jnp.where`, `jnp.remainder`, ...) once
per distinct traced jaxpr, and whether two calls share one depends on its trace caches (the g-l
program traced after the a-f tests had 538 private functions, traced first 531: the same
computation, another key). So `Worlds` clears JAX's caches before it lowers its program, here
and in the suite alike. It checks nothing: a failure here only costs the tests their compile.
"""

import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from conftest import Worlds  # noqa: E402  (also sets the cache and XLA_FLAGS)


def main() -> None:
    from graspjax.config import Config
    from graspjax.sim import scene_for

    for letters, collide in (("abcdef", True), ("ghijkl", False)):
        Worlds(scene_for(tuple(letters), Config(), collide))


if __name__ == "__main__":
    main()
