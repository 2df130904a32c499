"""The store of executables: compiled once, loaded onto any device of the kind, in any process,
with the same results."""

import os
import subprocess
import sys
import textwrap

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from graspjax.runtime import executables, exported


def _fn(x, k):
    return jnp.sin(x) * k, jnp.cumsum(x)


ARGS = (jax.ShapeDtypeStruct((5,), jnp.float32), jax.ShapeDtypeStruct((), jnp.float32))
VALUES = (jnp.linspace(0.0, 1.0, 5, dtype=jnp.float32), jnp.float32(3.0))


@pytest.fixture
def stores(tmp_path, monkeypatch):
    monkeypatch.setattr(exported, "store", lambda: tmp_path / "exported")
    monkeypatch.setattr(executables, "store", lambda: tmp_path / "executables")
    return tmp_path


def _compiled(donate=()):
    portable = exported.export(_fn, ARGS, ("executables test",))
    lowered = portable.lower(donate_argnums=donate)
    return executables.compile_on(lowered, portable.name, donate, jax.devices()[0])


def test_compiled_once_then_loaded_with_the_same_results(stores):
    first, source = _compiled()
    assert source == "compiled" and len(list((stores / "executables").glob("*.xla"))) == 1
    second, source = _compiled()
    assert source == "loaded"
    expected = jax.jit(_fn)(*VALUES)
    for compiled in (first, second):
        for x, y in zip(compiled(*VALUES), expected, strict=True):
            np.testing.assert_array_equal(np.asarray(x), np.asarray(y))


def test_donated_arguments_key_another_executable(stores):
    _compiled()
    assert _compiled(donate=(0,))[1] == "compiled"
    assert len(list((stores / "executables").glob("*.xla"))) == 2


def test_a_file_that_does_not_load_is_compiled_again_and_replaced(stores):
    _compiled()
    [path] = (stores / "executables").glob("*.xla")
    path.write_bytes(path.read_bytes()[:4] + b"not an executable")
    compiled, source = _compiled()
    assert source == "compiled" and path.stat().st_size > 100
    np.testing.assert_array_equal(np.asarray(compiled(*VALUES)[1]), np.cumsum(VALUES[0]))
    assert _compiled()[1] == "loaded"


def test_without_a_store_nothing_is_kept(tmp_path, monkeypatch):
    monkeypatch.setattr(exported, "store", lambda: None)
    monkeypatch.setattr(executables, "store", lambda: None)
    assert _compiled()[1] == _compiled()[1] == "compiled"
    assert not list(tmp_path.iterdir())


@pytest.mark.slow  # starts Python processes that import JAX (`pytest -m "not slow"`: README)
def test_another_process_with_two_devices_loads_it_onto_its_second_device(tmp_path):
    """A process with one CPU device compiles; a process with two (another topology, and a
    device of another id) loads the executable onto device 1 without compiling, with the
    same results."""
    code = textwrap.dedent(f"""
        import sys
        import jax, jax.numpy as jnp, numpy as np
        sys.path.insert(0, {os.path.dirname(__file__)!r})
        jax.config.update("jax_compilation_cache_dir", {str(tmp_path)!r})
        from test_executables import ARGS, VALUES, _fn
        from graspjax.runtime import executables, exported
        device = jax.devices()[-1]
        portable = exported.export(_fn, ARGS, ("executables test",))
        compiled, source = executables.compile_on(portable.lower(), portable.name, (), device)
        out = compiled(*jax.device_put(VALUES, device))
        assert out[0].devices() == {{device}}
        print(source, device.id, repr(np.asarray(out[0]).tolist()))
    """)
    said = []
    for count in (1, 2):
        flags = f"{os.environ.get('XLA_FLAGS', '')} --xla_force_host_platform_device_count={count}"
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              env={**os.environ, "XLA_FLAGS": flags, "JAX_PLATFORMS": "cpu"},
                              timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        said.append(done.stdout.split(maxsplit=2))
    (first, first_id, first_out), (second, second_id, second_out) = said
    assert (first, first_id, second, second_id) == ("compiled", "0", "loaded", "1")
    assert first_out == second_out == repr(np.asarray(jax.jit(_fn)(*VALUES)[0]).tolist()) + "\n"


@pytest.mark.slow  # starts Python processes that import JAX (`pytest -m "not slow"`: README)
def test_an_executable_read_from_jax_s_cache_is_not_kept(tmp_path):
    """On the CPU an executable JAX read from its own cache serializes without its functions'
    code (a later call fails: "Function ... not found"), so it is not kept: with the store
    emptied, a process that finds the program in JAX's cache runs it and keeps nothing; one
    that finds it in neither compiles and keeps it."""
    code = textwrap.dedent(f"""
        import pathlib, sys
        import jax, jax.numpy as jnp, numpy as np
        jax.config.update("jax_compilation_cache_dir", {str(tmp_path)!r})
        jax.config.update("jax_persistent_cache_min_compile_time_secs", 0)
        from graspjax.runtime import executables, exported

        def f(x):  # fusions whose code a re-serialized copy would lack
            return jnp.argmax(x, axis=1), jnp.sort(x, axis=0).sum()

        x = jnp.asarray(np.arange(60.0).reshape(6, 10) % 7, jnp.float32)
        portable = exported.export(f, (jax.ShapeDtypeStruct(x.shape, x.dtype),), ("hit",))
        compiled, source = executables.compile_on(portable.lower(), portable.name, (),
                                                  jax.devices()[0])
        kept = len(list(pathlib.Path({str(tmp_path / "executables")!r}).glob("*.xla")))
        print(source, kept, np.asarray(compiled(x)[0]).tolist())
    """)

    def run():
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              env={**os.environ, "JAX_PLATFORMS": "cpu"}, timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        return done.stdout.split(maxsplit=2)

    argmax = repr([int(np.argmax(np.arange(60.0).reshape(6, 10)[i] % 7)) for i in range(6)])
    assert run() == ["compiled", "1", argmax + "\n"]  # compiled, kept
    assert run() == ["loaded", "1", argmax + "\n"]  # loaded from the store
    for path in (tmp_path / "executables").glob("*.xla"):
        path.unlink()
    assert run() == ["cached", "0", argmax + "\n"]  # JAX's cache: run, not kept


def test_threads_that_ask_at_once_compile_it_once(stores):
    """Two threads (two devices' copies in a run) ask for one executable at once: one compiles
    it, the other waits and loads it."""
    import concurrent.futures

    portable = exported.export(_fn, ARGS, ("executables test",))
    lowered = portable.lower()
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        done = list(pool.map(lambda _: executables.compile_on(lowered, portable.name, (),
                                                              jax.devices()[0]), range(2)))
    assert sorted(source for _, source in done) == ["compiled", "loaded"]
    for compiled, _ in done:
        np.testing.assert_array_equal(np.asarray(compiled(*VALUES)[1]), np.cumsum(VALUES[0]))
