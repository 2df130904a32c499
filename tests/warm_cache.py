"""Compile, beside the suite, the physics programs its late tests would otherwise compile first.

conftest starts this in a second process when the session starts, while the suite's first
modules leave a core idle (XLA compiles mostly on one). It runs `test_experiment`'s CLI
commands (`WARM_RUNS`), whose programs' exported forms and compiled code the module's fixtures
then load (about 3 minutes of tracing and compiling on the 2-core machine), and builds the
`conftest.Worlds` of `conftest.PHYSICS_SCENES`, whose physics programs compile
ahead of time into the persistent compilation cache for `test_physics`, their first user
(about 45 s each on an idle machine, 90-170 s beside the suite). A test module reached
before its programs are ready compiles them itself.

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

from conftest import PHYSICS_SCENES, Worlds  # noqa: E402  (also sets the cache and XLA_FLAGS)


def main() -> None:
    import tempfile

    from test_experiment import WARM_RUNS

    from graspjax.batch import estimate
    from graspjax.cli import main as cli

    # Its runs warm the caches, they are no user's: what they take beside the suite is not
    # kept for `--dry-run`'s estimates, whose test reads the store a run of its own just wrote.
    estimate.record_timings = lambda *args, **kwargs: None

    with tempfile.TemporaryDirectory() as folder:  # the runs' files are not needed
        for i, args in enumerate(WARM_RUNS):
            cli([*args, "--out", os.path.join(folder, str(i))])
    for scene in PHYSICS_SCENES:
        Worlds(scene())


if __name__ == "__main__":
    main()
