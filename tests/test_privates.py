"""`privates.quiet_import`: imports that print are silenced without losing the process's stdout,
whatever threads import at once (programs are traced in threads)."""

import sys
import threading
import time

from graspjax import privates
from graspjax.privates import quiet_import


def _slow_printing_module(folder, name, seconds):
    (folder / f"{name}.py").write_text(
        f"import time\nprint('{name} says hello')\ntime.sleep({seconds})\n")


def test_imports_that_overlap_in_two_threads_leave_stdout_as_it_was(tmp_path, monkeypatch,
                                                                    capsys):
    """Two imports that print and overlap in time (the second starts while the first is still
    importing, and ends after it): unserialized `redirect_stdout` swaps would leave the first
    one's buffer as `sys.stdout`, and every later print of the process would be lost."""
    _slow_printing_module(tmp_path, "graspjax_test_slow_first", 0.4)
    _slow_printing_module(tmp_path, "graspjax_test_slow_second", 0.4)
    monkeypatch.syspath_prepend(str(tmp_path))
    stdout = sys.stdout
    first = threading.Thread(target=quiet_import, args=("graspjax_test_slow_first",))
    second = threading.Thread(target=quiet_import, args=("graspjax_test_slow_second",))
    first.start()
    time.sleep(0.1)
    second.start()
    first.join()
    second.join()
    assert sys.stdout is stdout
    print("still heard")
    assert capsys.readouterr().out == "still heard\n"  # the imports' own prints were dropped
    for name in ("graspjax_test_slow_first", "graspjax_test_slow_second"):
        assert sys.modules.pop(name).__name__ == name


def test_a_module_already_imported_is_returned_without_swapping_stdout(monkeypatch):
    def no_swap(_):
        raise AssertionError("sys.stdout swapped for a module already imported")

    monkeypatch.setattr(privates.contextlib, "redirect_stdout", no_swap)
    assert privates.quiet_import("json") is sys.modules["json"]
