"""The runtime wing: XLA's flags set before JAX starts, the user's flags kept."""

import os
import subprocess
import sys

import pytest


def test_importing_graspjax_starts_no_backend_so_xla_flags_apply():
    """XLA reads XLA_FLAGS when the first backend starts: the CLI's flags take effect only if
    importing graspjax (any of its modules) starts none, and XLA accepts every one of them."""
    code = """
import os

import pytest
import importlib, pkgutil
import graspjax
for module in pkgutil.walk_packages(graspjax.__path__, "graspjax."):
    importlib.import_module(module.name)
from jax._src import xla_bridge
assert not xla_bridge.backends_are_initialized(), "a backend started at import"
graspjax.runtime.xla.set_xla_flags(deterministic=True)
import jax
jax.numpy.zeros(1).block_until_ready()
print(os.environ["XLA_FLAGS"])
"""
    env = {k: v for k, v in os.environ.items() if k != "XLA_FLAGS"}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["--xla_cpu_experimental_ynn_fusion_type=",
                                   "--xla_gpu_deterministic_ops=true",
                                   "--xla_gpu_gemm_rewrite_size_threshold=300"]


def test_xla_flags_keep_the_user_s_and_fast_drops_only_the_gpu_s():
    from graspjax.runtime.xla import with_xla_flags

    assert with_xla_flags("", deterministic=False) == "--xla_cpu_experimental_ynn_fusion_type="
    mine = "--xla_cpu_experimental_ynn_fusion_type=dot --xla_gpu_gemm_rewrite_size_threshold=9"
    assert with_xla_flags(mine) == mine + " --xla_gpu_deterministic_ops=true"
    assert with_xla_flags(with_xla_flags("")) == with_xla_flags("")  # nothing added twice


def test_devices_take_memory_as_needed_unless_the_user_says_otherwise(monkeypatch, tmp_path):
    """The CLI sets JAX's preallocation off before any backend starts; a value the user set
    stays."""
    from graspjax.cli import main

    monkeypatch.delenv("XLA_PYTHON_CLIENT_PREALLOCATE", raising=False)
    bad_table = ["run", "--table", "9", "--out", str(tmp_path / "run")]  # stops before a run
    assert main(bad_table) == 2
    assert os.environ["XLA_PYTHON_CLIENT_PREALLOCATE"] == "false"
    monkeypatch.setenv("XLA_PYTHON_CLIENT_PREALLOCATE", "true")
    assert main(bad_table) == 2
    assert os.environ["XLA_PYTHON_CLIENT_PREALLOCATE"] == "true"
    assert not (tmp_path / "run").exists()


def test_the_compile_cache_is_created_private_and_refused_when_others_may_write_it(
        tmp_path, monkeypatch, capsys):
    """What the cache holds runs as code (exported programs are unpickled): the CLI creates it
    private and refuses, in one line naming it and before anything is read from it or any run
    starts, a cache folder (or a store in it) that others may write or another user owns."""
    from graspjax.cli import main
    from graspjax.errors import InputError
    from graspjax.runtime.xla import compilation_cache

    cache = tmp_path / "new" / "cache"
    monkeypatch.setenv("GRASPJAX_CACHE", str(cache))
    monkeypatch.setattr("jax.config.update", lambda *args: None)  # the session's cache stays
    compilation_cache()
    assert cache.stat().st_mode & 0o777 == 0o700
    for others in (0o002, 0o020):  # o+w, g+w
        cache.chmod(0o755 | others)
        with pytest.raises(InputError, match=f"the compile cache {cache} is writable by other"):
            compilation_cache()
        out = tmp_path / "run"
        assert main(["run", "--setup", "1", "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert f"compile cache {cache} is writable" in err and err.count("\n") == 1
        assert not out.exists()
    cache.chmod(0o755)
    compilation_cache()  # readable by others is fine: nobody else can put anything there
    monkeypatch.setattr("os.geteuid", lambda: cache.stat().st_uid + 1)
    with pytest.raises(InputError, match=f"the compile cache {cache} belongs to another user"):
        compilation_cache()


def test_a_compile_cache_that_is_a_file_is_one_line_saying_so(tmp_path, monkeypatch, capsys):
    """Not the OSError of a folder made in it, with a hint to --resume a run."""
    from graspjax.cli import main

    cache = tmp_path / "cache"
    cache.write_text("")
    monkeypatch.setenv("GRASPJAX_CACHE", str(cache))
    monkeypatch.setattr("jax.config.update", lambda *args: None)  # the session's cache stays
    out = tmp_path / "run"
    assert main(["run", "--setup", "1", "--out", str(out), "--dry-run"]) == 2
    assert capsys.readouterr().err == (f"graspjax: error: the compile cache {cache} "
                                       "(GRASPJAX_CACHE) is not a folder: set GRASPJAX_CACHE to a "
                                       "folder (0: no cache)\n")
    assert not out.exists()


def test_a_store_in_the_cache_that_others_may_write_is_refused_before_it_is_read(tmp_path):
    """`stores.store`, which every read of the exported programs and resting poses goes through,
    checks the cache and the store folder each time; `stores.keep` creates both private."""
    import jax

    from graspjax.errors import InputError
    from graspjax.runtime.stores import keep, store

    session = jax.config.jax_compilation_cache_dir
    jax.config.update("jax_compilation_cache_dir", str(tmp_path / "cache"))
    try:
        keep(store("exported") / "program", b"data")
        folders = (tmp_path / "cache", store("exported"))
        assert {p.stat().st_mode & 0o777 for p in folders} == {0o700}
        (tmp_path / "cache" / "exported").chmod(0o777)
        with pytest.raises(InputError, match="cache .*/cache/exported is writable by other"):
            store("exported")
    finally:
        jax.config.update("jax_compilation_cache_dir", session)
