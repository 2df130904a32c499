"""`privates.quiet_import`: mjx's first import prints, and is silenced without losing the
process's stdout, whatever threads import at once (programs are traced in threads)."""

import sys
import threading
import time

from graspjax import privates
from graspjax.privates import quiet_import


def _slow_printing_package(folder, name, seconds):
    (folder / name).mkdir()
    (folder / name / "__init__.py").write_text(
        f"import time\nprint('{name} says hello')\ntime.sleep({seconds})\n")
    (folder / name / "part.py").write_text("VALUE = 1\n")


def test_imports_that_overlap_in_two_threads_leave_stdout_as_it_was(tmp_path, monkeypatch,
                                                                    capsys):
    """Two noisy packages imported in two threads, overlapping in time (the second starts while
    the first is still importing, and ends after it): unserialized `redirect_stdout` swaps
    would leave the first one's buffer as `sys.stdout`, and every later print of the process
    would be lost."""
    names = ("graspjax_test_noisy_first", "graspjax_test_noisy_second")
    for name in names:
        _slow_printing_package(tmp_path, name, 0.4)
    monkeypatch.syspath_prepend(str(tmp_path))
    stdout = sys.stdout
    threads = [threading.Thread(target=quiet_import, args=(f"{name}.part", name))
               for name in names]
    threads[0].start()
    time.sleep(0.1)
    threads[1].start()
    for thread in threads:
        thread.join()
    assert sys.stdout is stdout
    print("still heard")
    assert capsys.readouterr().out == "still heard\n"  # the packages' own prints were dropped
    for name in names:
        assert sys.modules.pop(f"{name}.part").VALUE == 1
        assert sys.modules.pop(name).__name__ == name


def test_only_the_noisy_package_s_first_import_swaps_stdout(monkeypatch):
    """mjx is imported (`graspjax.sim.scene`), and nothing else ever swaps: neither a module of
    mjx's nor JAX's private ones."""
    import graspjax.sim.scene  # noqa: F401  (mjx's first import)

    def no_swap(_):
        raise AssertionError("sys.stdout swapped")

    monkeypatch.setattr(privates.contextlib, "redirect_stdout", no_swap)
    assert privates.quiet_import("mujoco.mjx._src.math") is sys.modules["mujoco.mjx._src.math"]
    assert privates.quiet_import("jax._src.compiler") is sys.modules["jax._src.compiler"]
