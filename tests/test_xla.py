"""The runtime wing: XLA's flags set before JAX starts, the user's flags kept."""

import os
import subprocess
import sys


def test_importing_graspjax_starts_no_backend_so_xla_flags_apply():
    """XLA reads XLA_FLAGS when the first backend starts: the CLI's flags take effect only if
    importing graspjax (any of its modules) starts none, and XLA accepts every one of them."""
    code = """
import os
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
