"""Every private name of MuJoCo MJX and JAX that graspjax uses, and nowhere else.

Checked against mujoco-mjx 3.17.0 with jax 0.10.2 (Python 3.11, CPU), jax 0.11.2 (Python
3.12, CUDA) and jax 0.12.0.1 (Python 3.12.1, CPU: every name below resolves and the suite's
fast tests, the physics, the executables' store and the distributed runs pass; not yet on a
GPU); pyproject allows those minor versions. JAX 0.13 is not allowed until it is checked the
same way: the names below looked up again in its JAX and the MJX release built for it. An
upgrade of either starts here: each name below says what it is and who uses it, and
`tests/test_architecture.py` keeps private access out of every other module. Nothing is
imported until a name is first used, so importing this module loads neither MuJoCo nor JAX's
internals (`graspjax report` loads no simulator).

MJX's data and model keep the JAX implementation's fields (contacts, constraint rows, model
flags) in a private `_impl`: `impl` reads them and `with_impl` replaces them.
"""

from __future__ import annotations

import contextlib
import importlib
import io
import sys
import threading
from typing import Any

# name here: (module, its name there), what it is, and who uses it
_NAMES = {
    # MJX's collision driver (sim/physics/collision.py: groups cut into parts)
    "COLLISION_FUNCTIONS": ("mujoco.mjx._src.collision_driver", "_COLLISION_FUNC"),
    "numeric": ("mujoco.mjx._src.collision_driver", "_numeric"),  # a model's numeric field
    "geom_groups": ("mujoco.mjx._src.collision_driver", "_geom_groups"),
    "contact_groups": ("mujoco.mjx._src.collision_driver", "_contact_groups"),
    # MJX's convex collision (sim/physics/convex.py: hull pairs on grids)
    "ConvexInfo": ("mujoco.mjx._src.collision_types", "ConvexInfo"),
    "collider": ("mujoco.mjx._src.collision_convex", "collider"),
    "project_poly_onto_poly_plane": ("mujoco.mjx._src.collision_convex",
                                     "_project_poly_onto_poly_plane"),
    "project_poly_onto_plane": ("mujoco.mjx._src.collision_convex", "_project_poly_onto_plane"),
    "point_in_front_of_plane": ("mujoco.mjx._src.collision_convex", "_point_in_front_of_plane"),
    "manifold_points": ("mujoco.mjx._src.collision_convex", "_manifold_points"),
    # MJX's vector helpers (convex.py, solver.py)
    "normalize": ("mujoco.mjx._src.math", "normalize"),
    "norm": ("mujoco.mjx._src.math", "norm"),
    "make_frame": ("mujoco.mjx._src.math", "make_frame"),
    "closest_segment_to_segment_points": ("mujoco.mjx._src.math",
                                          "closest_segment_to_segment_points"),
    # MJX's Newton solver (sim/physics/solver.py: the cone Hessian as one product)
    "SolverContext": ("mujoco.mjx._src.solver", "Context"),
    "rescale": ("mujoco.mjx._src.solver", "_rescale"),
    "linesearch": ("mujoco.mjx._src.solver", "_linesearch"),
    "mul_m": ("mujoco.mjx._src.support", "mul_m"),
    "full_m": ("mujoco.mjx._src.support", "full_m"),
    # JAX: each equation's source line (sim/physics/scatters.py re-binds equations)
    "source_info_util": ("jax._src.source_info_util", None),
    # JAX: whether a backend has started (runtime/xla.py: XLA's flags are read then)
    "backends_are_initialized": ("jax._src.xla_bridge", "backends_are_initialized"),
    # JAX: the distributed runtime's state, whose client holds barriers (runtime/distributed.py)
    "distributed_state": ("jax._src.distributed", "global_state"),
    # JAX: the thread-local switch to one source line per operation (runtime/exported.py)
    "include_full_tracebacks_in_locations": ("jax._src.config",
                                             "include_full_tracebacks_in_locations"),
    # JAX: a serialized executable read back, the compile options a device's copy is loaded
    # with, and the list of devices it runs on (load_executable: runtime/executables.py)
    "ExecutableUnpickler": ("jax.experimental.serialize_executable", "_JaxPjrtUnpickler"),
    "get_compile_options": ("jax._src.compiler", "get_compile_options"),
    "xla_client": ("jax._src.lib", "xla_client"),
}


def __getattr__(name: str) -> Any:
    """The private `name` of `_NAMES`, imported on first use."""
    if name not in _NAMES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    module_name, attribute = _NAMES[name]
    module = quiet_import(module_name)  # mjx prints that its optional backends are missing
    value = module if attribute is None else getattr(module, attribute)
    globals()[name] = value
    return value


_QUIET = threading.Lock()  # the one swap of stdout, in every thread of the process


def quiet_import(module_name: str, noisy: str = "mujoco.mjx") -> Any:
    """`importlib.import_module(module_name)`. The package `noisy` prints on its first import
    (mjx: that its optional backends are missing): when `module_name` is in it and it is not
    imported yet, it is imported first with stdout dropped. `contextlib.redirect_stdout` swaps
    the process's one `sys.stdout`, and programs are traced in threads: two swaps that overlap
    can leave it swapped for good (every later print of the process lost), and a print of
    another thread during a swap is lost. So there is one swap per process, under a lock, and
    none for anything else."""
    if (module_name == noisy or module_name.startswith(noisy + ".")) and noisy not in sys.modules:
        with _QUIET:
            if noisy not in sys.modules:  # another thread may have imported it meanwhile
                with contextlib.redirect_stdout(io.StringIO()):
                    importlib.import_module(noisy)
    return importlib.import_module(module_name)  # waits for another thread still importing it

def impl(x: Any) -> Any:
    """The JAX implementation's private fields of an `mjx.Data` or `mjx.Model` (contacts,
    constraint rows and forces, friction-loss flags)."""
    return x._impl


def distributed_client() -> Any:
    """The client of JAX's distributed runtime (`jax.distributed.initialize`): its barriers
    and key-value store."""
    return __getattr__("distributed_state").client


def with_impl(data: Any, **fields: Any) -> Any:
    """`data` (an `mjx.Data`) with the named private fields replaced."""
    return data.tree_replace({f"_impl.{name}": value for name, value in fields.items()})


def load_executable(serialized: bytes, in_tree: Any, out_tree: Any, device: Any) -> Any:
    """A single-device executable serialized by `jax.experimental.serialize_executable.serialize`
    on any device of the same kind, loaded onto `device` (a `jax.stages.Compiled`): every device
    it names becomes `device`, and it is loaded with `device`'s compile options. JAX's public
    `deserialize_and_load` keeps the device it was compiled for, which in another process or
    on another device of this one is not this device (the same as JAX's own compilation cache
    does on GPUs, where its key leaves the device out)."""
    import jax
    import numpy as np

    base = __getattr__("ExecutableUnpickler")
    options = __getattr__("get_compile_options")(num_replicas=1, num_partitions=1,
                                                 device_assignment=np.array([[device.id]]))
    devices = __getattr__("xla_client").DeviceList((device,))

    class OnDevice(base):
        def persistent_load(self, pid):
            if pid[0] == "device":
                return device
            if pid[0] == "exec":
                return self.backend.deserialize_executable(pid[1], executable_devices=devices,
                                                           compile_options=options)
            return super().persistent_load(pid)

    unloaded, args_info, no_kwargs = OnDevice(io.BytesIO(serialized), device.client,
                                              [device]).load()
    return jax.stages.Compiled(unloaded.load(), [], in_tree.unflatten(args_info), out_tree,
                               no_kwargs=no_kwargs)
