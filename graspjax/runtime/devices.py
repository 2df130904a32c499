"""Work played on every local device, one thread per device: each takes the first waiting item
whose program is ready on it, plays it, and hands its result to the caller as it finishes.

Nothing here knows what an item is: `batch/schedule.py` plays a run's chunks through
`play_on_devices`, with what each waits for (its program's compiles, `runtime.compiles`)
and how one is played.
"""

from __future__ import annotations

import concurrent.futures
import queue
import threading
from collections.abc import Callable, Iterator
from typing import Any

from graspjax.runtime.compiles import take_ready


def play_on_devices(waiting: list, devices: int,
                    waits_for: Callable[[Any, int], list[concurrent.futures.Future]],
                    play: Callable[[Any, int], Any], lock: threading.Lock,
                    one_at_a_time: bool = False) -> Iterator[Any]:
    """Play every item of `waiting` (taken in order, as their `waits_for(item, device)` are
    done) on `devices` devices, `play(item, device)` in one thread per device; yield each
    result as it finishes. An item's error is raised here, once the caller reaches it; the
    devices then stop taking items. With `one_at_a_time`, a device takes its next item only once
    the caller has handled (asked for the result after) its last, whose results it may still
    hold (a run's kept views). Closing the generator early waits for the items playing to end.
    `lock` guards `waiting` (and what `play` shares with the caller)."""
    finished: queue.Queue = queue.Queue()  # (result or error, device) as items end
    stop = threading.Event()
    handled = [threading.Semaphore(1) for _ in range(devices)]  # the caller is done with it

    def device_loop(device: int) -> None:
        while True:
            if one_at_a_time:
                handled[device].acquire()
            item = take_ready(waiting, lambda item: waits_for(item, device), lock, stop)
            if item is None:
                break
            try:
                finished.put((play(item, device), device))
            except BaseException as error:  # handed to the caller, which raises it
                finished.put((error, device))
                break
        finished.put((None, device))

    threads = [threading.Thread(target=device_loop, args=(d,), daemon=True, name=f"device {d}")
               for d in range(devices)]
    for thread in threads:
        thread.start()
    try:
        running = len(threads)
        while running:
            result, device = finished.get()
            if result is None:
                running -= 1
                continue
            if isinstance(result, BaseException):
                raise result
            yield result
            if one_at_a_time:
                handled[device].release()
    finally:
        stop.set()
        for semaphore in handled:
            semaphore.release()
        for thread in threads:
            thread.join()
