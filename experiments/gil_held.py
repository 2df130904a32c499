"""Whether JAX's GPU start and a warm run's program loads keep Python's other threads waiting
(issue 53): a thread that sleeps 1 ms at a time notes how late it wakes while this process
(1) starts JAX's client, (2) makes every device's first allocation, each in a thread, (3)
imports graspjax.experiment, (4) loads Tables 1+2's programs for every device as a run does
(read from the store, lowered once, compiled for each device in threads, the scene's arrays put
there). One line per step: its seconds, the thread's latest wake-up and the seconds it lost to
wake-ups over 50 ms late. A step that held the GIL in C++ shows as long gaps; Python work in
other threads shows as gaps of a few ms (the interpreter switches threads every 5 ms). Run it
after a warm run, so that the store and XLA's cache hold the programs:

    CUDA_VISIBLE_DEVICES=0,1,2,3 python3 experiments/gil_held.py [TRIALS]

Results: results/benchmarks/ (stop 64).
"""
import concurrent.futures
import sys
import threading
import time

WAKES: list[tuple[float, float]] = []  # (when it woke, how late)


def heartbeat() -> None:
    while True:
        start = time.perf_counter()
        time.sleep(0.001)
        now = time.perf_counter()
        WAKES.append((now, now - start - 0.001))


def step(name: str, fn) -> None:
    begin = time.perf_counter()
    fn()
    end = time.perf_counter()
    late = [d for t, d in WAKES if begin <= t <= end + 0.05]
    print(f"{name:34s} {end - begin:6.2f} s  latest wake-up {max(late, default=0) * 1e3:7.1f} ms"
          f"  lost to >50 ms: {sum(d for d in late if d > 0.05):5.2f} s", flush=True)


def main() -> None:
    trials = int(sys.argv[1]) if len(sys.argv) > 1 else 4000
    threading.Thread(target=heartbeat, daemon=True).start()
    from graspjax.runtime import xla

    problem = xla.set_up(deterministic=True)  # as the command sets JAX up
    if problem:
        sys.exit(problem)
    import jax

    devices = []
    step("client (jax.local_devices)", lambda: devices.extend(jax.local_devices()))

    def first_allocations():
        with concurrent.futures.ThreadPoolExecutor(len(devices)) as pool:
            list(pool.map(lambda d: jax.device_put(0.0, d).block_until_ready(), devices))

    step(f"first allocations ({len(devices)} threads)", first_allocations)
    step("import graspjax.experiment", lambda: __import__("graspjax.experiment"))
    from graspjax.batch import plan, program
    from graspjax.config import Config

    groups = plan.plan([plan.table_job(1, trials), plan.table_job(2, trials)], [Config()], 0)
    for group in groups:
        load(program.program(group, plan.default_batch(), False), len(devices))


def load(p, devices: int) -> None:
    """One program read, lowered once and compiled for every device, each step timed."""
    lowered = []
    step(f"{p.name} read from the store", lambda: p.portable)
    step(f"{p.name} lowered once", lambda: lowered.extend(p.lower()))

    def compiled():
        with concurrent.futures.ThreadPoolExecutor(devices) as pool:
            list(pool.map(lambda d: p.compile(d, tuple(lowered), 0.0), range(devices)))

    step(f"{p.name} compiled, {devices} devices", compiled)


if __name__ == "__main__":
    main()
