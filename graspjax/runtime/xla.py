"""How a run sets up JAX before its first device call: XLA's flags (deterministic GPU ops,
the CPU's small products), device memory taken as needed, the persistent compilation cache, and
devices started early.
"""

from __future__ import annotations

import os
import re


def compilation_cache() -> None:
    """Keep compiled programs across runs (set GRASPJAX_CACHE=0 to switch off), in a folder
    created private (mode 0700); one that others may write or another user owns is refused
    before anything is read from it (`stores.check_cache`: what it holds runs as code)."""
    from graspjax.runtime.stores import check_cache

    folder = os.environ.get("GRASPJAX_CACHE", os.path.expanduser("~/.cache/graspjax/jax"))
    if folder in ("0", "off", ""):
        return
    try:
        os.makedirs(folder, mode=0o700, exist_ok=True)
    except OSError:  # left to XLA, which warns that it cannot write there
        pass
    check_cache(folder)
    import jax

    jax.config.update("jax_compilation_cache_dir", folder)
    jax.config.update("jax_persistent_cache_min_compile_time_secs", 1.0)


DETERMINISTIC = "--xla_gpu_deterministic_ops=true"
# Under deterministic ops XLA does not autotune its matrix kernels; products this small (combined
# non-batch elements of both operands) run faster as XLA's own loops than as untuned GEMMs: MJX's
# contact Jacobian rows, 3x3 by 3 x nv (bin scene 1.11x; results/benchmarks).
SMALL_DOTS = "--xla_gpu_gemm_rewrite_size_threshold=300"
# XLA's CPU backend (jaxlib 0.10.2 on) hands products to YNNPACK, whose per-call overhead
# outweighs the physics' products of a few elements, and whose kernels make a cached program slow
# to load (README's command is slower with it; results/benchmarks). An empty list of fusion
# types switches it off.
CPU_SMALL_DOTS = "--xla_cpu_experimental_ynn_fusion_type="


def with_xla_flags(flags: str, deterministic: bool = True) -> str:
    """XLA_FLAGS `flags` with graspjax's flags added where the flags do not already set them:
    the CPU's products as XLA loops (a jaxlib that knows the flag), and with `deterministic`
    the GPU's deterministic ops and small-product threshold."""
    added = []
    if knows_cpu_small_dots() and CPU_SMALL_DOTS.split("=")[0] not in flags:
        added.append(CPU_SMALL_DOTS)
    if deterministic and DETERMINISTIC not in flags:
        added.append(DETERMINISTIC)
    if deterministic and SMALL_DOTS.split("=")[0] not in flags:
        added.append(SMALL_DOTS)
    return " ".join([flags.strip(), *added]).strip()


def knows_cpu_small_dots() -> bool:
    """Whether the installed jaxlib has the YNNPACK flag (0.10.2 and 0.11.2 were checked); XLA
    stops the process on a flag it does not know."""
    from importlib.metadata import version

    return tuple(int(n) for n in re.findall(r"\d+", version("jaxlib"))[:3]) >= (0, 10, 2)


def memory_as_needed() -> None:
    """Let each device take memory as the run's programs need it, not JAX's default of 75 % at
    its start, unless XLA_PYTHON_CLIENT_PREALLOCATE says otherwise: a run needs a few GiB per
    device (`peak_gib` in timings.csv: 3.4 GiB at 2,048 worlds), reserving some 100 GiB took
    about 2 s per H200 at start and its release slowed the exit, and it leaves other processes
    on the same GPU (a second run, a trace helper) only the rest. The rows are the same either
    way (results/benchmarks). JAX reads it when it starts its first backend, like XLA_FLAGS."""
    os.environ.setdefault("XLA_PYTHON_CLIENT_PREALLOCATE", "false")


def set_xla_flags(deterministic: bool) -> str | None:
    """Set graspjax's XLA flags (`with_xla_flags`): XLA's GPU scatter-adds are not
    deterministic, so a GPU gets deterministic ops unless the user asks for speed; the CPU's
    flag is only speed. Returns why it cannot, else None.

    XLA reads its flags once, when JAX starts its first backend; so this runs before any device
    is used, and importing graspjax must start none (tests/test_cli.py checks both). Called
    from Python after JAX has started (several runs in one process), it can only check: a GPU
    without deterministic ops is refused.
    """
    flags = os.environ.get("XLA_FLAGS", "")
    wanted = with_xla_flags(flags, deterministic)
    if wanted == flags.strip():
        return None
    import jax

    from graspjax import privates

    if not privates.backends_are_initialized():
        os.environ["XLA_FLAGS"] = wanted
    elif deterministic and DETERMINISTIC not in flags and jax.default_backend() == "gpu":
        return ("JAX started on the GPU without deterministic ops: set XLA_FLAGS="
                f"{DETERMINISTIC} before JAX starts, or pass --fast")
    return None


def set_up(deterministic: bool) -> str | None:
    """Everything the command sets before JAX starts: XLA's flags (`set_xla_flags`), memory as
    needed (`memory_as_needed`) and the compilation cache; why it cannot, else None (nothing
    else is set then)."""
    problem = set_xla_flags(deterministic)
    if problem:
        return problem
    memory_as_needed()
    compilation_cache()
    return None


def start_devices() -> None:
    """Start JAX's devices in threads of their own, beside the simulation's imports (seconds:
    MJX and its mesh libraries), for every local device at once, not in a device's first chunk:
    on a GPU the driver and the client take one or two seconds, and a device's first
    allocation up to two more if JAX preallocates its memory (`memory_as_needed`). JAX's
    client holds the GIL for much of its start (1.05 of 1.68 s for 4 H200s, measured by a thread
    that sleeps 1 ms at a time: results/benchmarks/scaling_h200x4/host2/gil_held.txt), and the
    imports wait for it meanwhile.
    A failure is left to the run's own first use of the devices, which raises it again."""
    import threading

    import jax  # here, not in the thread: the main thread's imports import it too

    def start() -> None:
        try:
            devices = jax.local_devices()
        except Exception:  # the run's own first use of the devices raises it again
            return
        for device in devices:
            threading.Thread(target=first_allocation, args=(device,),
                             name=f"start-device-{device.id}").start()

    def first_allocation(device) -> None:
        try:
            jax.device_put(0.0, device).block_until_ready()
        except Exception:  # likewise
            pass

    threading.Thread(target=start, name="start-devices").start()
