"""The store of exported programs: traced once, loaded after, the same results either way."""

import dataclasses
import pathlib
import pickle
import re

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from graspjax.provenance import source_digest
from graspjax.runtime import exported


@jax.tree_util.register_dataclass
@dataclasses.dataclass
class Pair:
    a: jax.Array
    b: jax.Array


def _fn(pair: Pair, k):
    """A pytree in, a pytree with a None and a PRNG key out."""
    key = jax.random.fold_in(jax.random.key(0), k)
    return {"sum": pair.a + pair.b, "noise": jax.random.uniform(key, pair.a.shape),
            "nothing": None}, Pair(pair.a * k, pair.b)


ARGS = (Pair(jax.ShapeDtypeStruct((3,), jnp.float32), jax.ShapeDtypeStruct((3,), jnp.float32)),
        jax.ShapeDtypeStruct((), jnp.int32))
VALUES = (Pair(jnp.arange(3.0), jnp.ones(3)), jnp.int32(2))


@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.setattr(exported, "store", lambda: tmp_path)
    return tmp_path


def test_traced_once_then_loaded_with_the_same_results(store):
    first = exported.export(_fn, ARGS, ("pair", 1))
    assert not first.loaded and len(list(store.glob("*.jaxexport"))) == 1
    second = exported.export(_fn, ARGS, ("pair", 1))
    assert second.loaded
    expected = jax.jit(_fn)(*VALUES)
    for portable in (first, second):
        got = portable.jit()(*VALUES)
        assert jax.tree.structure(got) == jax.tree.structure(expected)
        for x, y in zip(jax.tree.leaves(got), jax.tree.leaves(expected), strict=True):
            np.testing.assert_array_equal(np.asarray(x), np.asarray(y))
    assert second.out_shapes()[0]["sum"].shape == (3,)
    assert second.in_shapes()[1].dtype == jnp.int32


def test_what_shapes_a_program_is_in_its_key(store):
    exported.export(_fn, ARGS, ("pair", 1))
    assert not exported.export(_fn, ARGS, ("pair", 2)).loaded  # another description
    longer = (Pair(jax.ShapeDtypeStruct((4,), jnp.float32),
                   jax.ShapeDtypeStruct((4,), jnp.float32)), ARGS[1])
    assert not exported.export(_fn, longer, ("pair", 1)).loaded  # other shapes
    assert len(list(store.glob("*.jaxexport"))) == 3


def test_a_program_keyed_by_part_of_its_arguments_loads_from_that_part_alone(store):
    """With `key`, the store finds the program from the key's shapes and the description: the
    rest of the arguments need not exist yet (a warm start loads before it builds the scene)."""
    assert exported.load(ARGS[1], ("pair", 1)) is None  # nothing stored yet
    traced = exported.export(_fn, ARGS, ("pair", 1), key=ARGS[1])
    assert not traced.loaded
    assert exported.stored(ARGS[1], ("pair", 1)) and not exported.stored(ARGS, ("pair", 1))
    found = exported.load(ARGS[1], ("pair", 1))
    assert found.loaded and found.in_tree == traced.in_tree
    np.testing.assert_array_equal(found.jit()(*VALUES)[0]["sum"], [1.0, 2.0, 3.0])
    assert exported.export(_fn, ARGS, ("pair", 1), key=ARGS[1]).loaded
    assert exported.load(ARGS[1], ("pair", 2)) is None  # another description


def test_an_unreadable_or_foreign_file_does_not_load(store):
    exported.export(_fn, ARGS, ("pair", 1))
    (path,) = store.glob("*.jaxexport")
    path.write_bytes(b"not a program")
    assert exported.load(ARGS, ("pair", 1)) is None
    path.write_bytes(pickle.dumps((exported.FORMAT + 1, None, None, b"")))
    assert exported.load(ARGS, ("pair", 1)) is None


def test_an_edit_anywhere_in_the_package_changes_the_key(tmp_path):
    """The key's source digest covers all of graspjax (a copy of the package digests as the
    package does), so an edit to a module outside `batch/` (the procedure) traces afresh."""
    import shutil

    import graspjax

    same, edited = tmp_path / "same" / "graspjax", tmp_path / "edited" / "graspjax"
    for copy in (same, edited):
        shutil.copytree(pathlib.Path(graspjax.__file__).parent, copy,
                        ignore=shutil.ignore_patterns("__pycache__"))
    with open(edited / "procedure.py", "a") as source:
        source.write("# an edit\n")
    assert source_digest(same) == source_digest()
    assert source_digest(edited) != source_digest()


def test_an_unreadable_file_is_traced_again_and_replaced(store):
    exported.export(_fn, ARGS, ("pair", 1))
    (path,) = store.glob("*.jaxexport")
    path.write_bytes(b"not a program")
    again = exported.export(_fn, ARGS, ("pair", 1))
    assert not again.loaded
    assert exported.export(_fn, ARGS, ("pair", 1)).loaded


def test_without_a_store_nothing_is_written(tmp_path, monkeypatch):
    monkeypatch.setattr(exported, "store", lambda: None)
    portable = exported.export(_fn, ARGS, ("pair", 1))
    assert not portable.loaded and not list(tmp_path.iterdir())
    np.testing.assert_array_equal(portable.jit()(*VALUES)[0]["sum"], [1.0, 2.0, 3.0])


def test_arguments_of_another_tree_are_refused(store):
    portable = exported.export(_fn, ARGS, ("pair", 1))
    with pytest.raises(TypeError, match="do not match"):
        portable.jit()({"a": VALUES[0].a, "b": VALUES[0].b}, VALUES[1])


def test_an_exported_operation_keeps_its_line_not_its_traceback(store):
    """XLA's GPU executable annotates every operation with its frames when it is created or
    loaded: the exported module gives each one source line, not the Python call stack."""
    def inner(x):
        return jnp.sin(x) * 2  # the operations' line

    def outer(pair: Pair):
        return inner(pair.a) + pair.b  # a call more between the operations and the export

    args = (ARGS[0],)
    text = exported.export(outer, args, ("outer",)).program.mlir_module()
    assert "callsite(" not in text and "test_exported.py" in text
    full = jax.export.export(jax.jit(lambda p: outer(p)))(*args).mlir_module()
    assert "callsite(" in full  # JAX's default, which the store does not keep


def _deepest_frame(compiled: jax.stages.Compiled) -> int:
    """The highest stack frame id in a compiled program's operations: frames are numbered as
    the module's frame index grows, so an operation that carries its caller's Python stack
    has an id beyond that stack's depth."""
    return max(int(i) for i in re.findall(r"stack_frame_id=(\d+)", compiled.as_text()))


def _called_from_deep(depth: int, fn):
    return fn() if depth == 0 else _called_from_deep(depth - 1, fn)


def test_a_lowered_program_does_not_give_its_operations_the_caller_s_stack(store):
    """Lowered with JAX's default, the operations inlined from an exported module carry the
    Python stack of the code that lowers it (a run's lowering thread); `Portable.lower` keeps
    them at their own line."""
    portable = exported.export(lambda pair: jnp.sin(pair.a) * 2 + pair.b, (ARGS[0],), ("sin",))
    ours = _called_from_deep(30, lambda: portable.lower())
    default = _called_from_deep(30, lambda: portable.jit().lower(*portable.in_shapes()))
    assert _deepest_frame(default.compile()) > 30
    ours = ours.compile(device_assignment=(jax.devices()[0],))
    assert _deepest_frame(ours) < 10
    np.testing.assert_allclose(ours(VALUES[0]), np.sin(np.arange(3.0)) * 2 + 1,
                               rtol=1e-6)
