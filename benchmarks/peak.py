"""Wall time and peak resident memory of one benchmark step, each measured in a fresh process."""

from __future__ import annotations

import multiprocessing
import queue as queues
import resource
import time


def _child(function, arguments, queue) -> None:
    start = time.perf_counter()
    try:
        result = function(*arguments)
    except Exception as error:  # reported by the parent, which would otherwise wait for a result forever
        queue.put(error)
        raise
    seconds = time.perf_counter() - start
    queue.put((seconds, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, result))


def _outcome(queue, process):
    """What the child reported, or None if it died without reporting (killed outright, e.g. out of memory)."""
    while True:
        try:
            return queue.get(timeout=1.0)
        except queues.Empty:
            if not process.is_alive():
                try:  # a report flushed while the child exited
                    return queue.get_nowait()
                except queues.Empty:
                    return None


def measure(function, *arguments):
    """Run ``function(*arguments)`` in a new (spawned) process.

    Returns (wall seconds of the call, peak resident memory of the process in MiB, the function's result).
    The function and its result must be picklable (a module-level function, plain values). An exception in the
    function is raised here as a RuntimeError.
    """
    context = multiprocessing.get_context("spawn")
    queue = context.Queue()
    process = context.Process(target=_child, args=(function, arguments, queue))
    process.start()
    outcome = _outcome(queue, process)
    process.join()
    if process.exitcode != 0:
        raise RuntimeError(f"benchmark step {function.__name__} failed (exit code {process.exitcode}): "
                           f"{outcome if isinstance(outcome, Exception) else 'no error reported'}")
    return outcome
