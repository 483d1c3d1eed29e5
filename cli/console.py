"""The ``surrogacy`` console script: one subcommand per pipeline stage.

Each stage package keeps its own subcommands in a ``commands`` module with a ``register(subparsers)``
function; this file only collects them, with the demo's (``cli.commands``). ``surrogacy <stage> --help`` documents each one.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import importlib
import io
import json
import os
import resource
import signal
import sys
import threading
import time
from pathlib import Path

STAGE_COMMANDS = ("cli.commands", "pipeline.commands", "geometry.commands", "fem.commands", "reduction.commands",
                  "experiment.commands", "virtual_experiment.commands", "study.commands", "calibration.commands",
                  "discrepancy.commands", "report.commands")


def parser() -> argparse.ArgumentParser:
    """The argument parser with every stage subcommand."""
    root = argparse.ArgumentParser(prog="surrogacy", description=__doc__.splitlines()[0])
    root.add_argument("--run-log", type=Path, metavar="FILE",
                      help="append one JSON line per run to FILE: the command line, its wall time (s), peak memory "
                           "(MB) and exit status (the report's per-stage timings)")
    subparsers = root.add_subparsers(dest="command", required=True, metavar="STAGE")
    for module_name in STAGE_COMMANDS:
        importlib.import_module(module_name).register(subparsers)
    return root


INTERRUPTED = threading.Event()  # set by the first Ctrl-C, even where Python swallows its KeyboardInterrupt


def interrupt(signal_number, frame) -> None:
    """Ctrl-C: remember it, then raise KeyboardInterrupt as Python's own handler does. Python ignores an exception
    raised while it runs a weakref callback or ``__del__`` (a finalizer, an import's module-lock callback);
    ``redeliver_swallowed`` then sends the signal again, so the command still stops at once with 130."""
    INTERRUPTED.set()
    raise KeyboardInterrupt


def raise_if_interrupted() -> None:
    """Raise KeyboardInterrupt where a Ctrl-C came but its exception was swallowed (see ``interrupt``)."""
    if INTERRUPTED.is_set():
        raise KeyboardInterrupt


TERMINATED = threading.Event()  # set by SIGTERM


def terminate(signal_number, frame) -> None:
    """SIGTERM as a clean exit: the stage's ``finally`` blocks run (temporary files removed) before it ends."""
    TERMINATED.set()
    raise SystemExit(128 + signal_number)


def redeliver_swallowed(unraisable, fallback=sys.__unraisablehook__) -> None:
    """``sys.unraisablehook`` while a command runs: the KeyboardInterrupt or SystemExit of ``interrupt`` or
    ``terminate``, raised inside a finalizer and ignored there by Python, is not printed; its signal is sent to the
    main thread again 10 ms later, when the finalizer has returned, so the command ends as if it had come then.
    Any other unraisable exception goes to ``fallback``, the hook in place before (Python's own prints it)."""
    swallowed = {KeyboardInterrupt: (INTERRUPTED, signal.SIGINT), SystemExit: (TERMINATED, signal.SIGTERM)}
    event, signal_number = swallowed.get(unraisable.exc_type, (None, None))
    if event is None or not event.is_set():
        fallback(unraisable)
        return
    main_thread = threading.main_thread().ident
    threading.Timer(0.01, signal.pthread_kill, args=(main_thread, signal_number)).start()


def peak_memory_mb() -> float:
    """Peak resident memory (MB) of this process or of the largest of its finished children (dask workers,
    solvers run as subprocesses), whichever is larger (getrusage; ru_maxrss in kB on Linux)."""
    return max(resource.getrusage(who).ru_maxrss for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN)) / 1024


def log_run(log: Path, command: list[str], wall_s: float, status: int) -> None:
    """Append one line of strict JSON (the stage's command line, wall time, peak memory, exit status: finite
    numbers) to ``log``: one short line written in append mode, so concurrent runs never interleave inside a line.
    A log whose last line was cut short (no line end) gets a line end first, so the record stays a line of its own."""
    record = {"command": ["surrogacy", *command], "finished": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
              "wall_s": round(wall_s, 2), "peak_memory_mb": round(peak_memory_mb(), 1), "status": status}
    log.parent.mkdir(parents=True, exist_ok=True)
    with open(log, "ab+") as stream:
        size = stream.seek(0, io.SEEK_END)
        cut = size > 0 and os.pread(stream.fileno(), 1, size - 1) != b"\n"
        stream.write((("\n" if cut else "") + json.dumps(record, allow_nan=False) + "\n").encode())


def run(arguments) -> int:
    """Run the stage ``arguments`` selects; errors in the inputs print one clear line and give status 2; SIGTERM
    and Ctrl-C end it cleanly (no temporary file left) with 143 and 130."""
    try:
        arguments.run(arguments)
        raise_if_interrupted()
    except KeyboardInterrupt:
        return interrupted(arguments.command)
    except Exception as error:
        # After Ctrl-C or SIGTERM any exception is the interruption's: a C extension that receives the signal's
        # exception while it runs may return another in its place (numba's dispatcher, interrupted as it
        # compiles, raises SystemError "returned a result with an exception set").
        if TERMINATED.is_set():
            raise SystemExit(128 + signal.SIGTERM) from None
        if INTERRUPTED.is_set():
            return interrupted(arguments.command)
        if isinstance(error, (ValueError, OSError)):  # bad input, or a file or folder that cannot be read or written
            message = " ".join(line.strip() for line in str(error).splitlines())  # one line, whatever a library says
            print(f"surrogacy {arguments.command}: error: {message}", file=sys.stderr)
            return 2
        raise  # a bug: traceback and exit 1
    return 0


def interrupted(command: str) -> int:
    """The one line of an interrupted stage; its exit status, 130."""
    print(f"surrogacy {command}: interrupted; finished results are kept, rerun to go on", file=sys.stderr)
    return 130


@contextlib.contextmanager
def stage_signals():
    """Ctrl-C (``interrupt``) and SIGTERM (``terminate``) handled as clean exits while a command runs, the previous
    handlers back after it (``main`` also runs in-process, in the tests). Signals reach only the main thread."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    INTERRUPTED.clear()
    TERMINATED.clear()
    previous = {number: signal.signal(number, handler)
                for number, handler in ((signal.SIGINT, interrupt), (signal.SIGTERM, terminate))}
    previous_hook = sys.unraisablehook
    sys.unraisablehook = functools.partial(redeliver_swallowed, fallback=previous_hook)
    try:
        yield
    finally:
        sys.unraisablehook = previous_hook
        for number, handler in previous.items():
            signal.signal(number, handler)


@contextlib.contextmanager
def ctrl_c_held():
    """Ctrl-C held back (the signal blocked) in the block and delivered right after it, in this code. Python
    swallows a KeyboardInterrupt raised inside its import machinery's callbacks, printing a traceback; the
    stages' imports are therefore run with SIGINT blocked, and a Ctrl-C in them ends the command when they
    finish (a few seconds)."""
    held = threading.current_thread() is threading.main_thread()
    if held:
        signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
    finally:
        if held:
            signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGINT})


def main(argv: list[str] | None = None) -> int:
    """Parse the command line, run the stage, and log the run where ``--run-log`` asks."""
    start = time.perf_counter()  # the stages' imports count
    argv = sys.argv[1:] if argv is None else list(argv)
    with stage_signals():
        try:
            with ctrl_c_held():  # importing every stage takes seconds, in which Ctrl-C may come
                arguments = parser().parse_args(argv)
            raise_if_interrupted()
        except KeyboardInterrupt:
            print("surrogacy: interrupted; finished results are kept, rerun to go on", file=sys.stderr)
            return 130
        status = 1  # an exception that escapes run() is a bug: traceback and exit 1
        try:
            status = run(arguments)
        except SystemExit as exit_:  # SIGTERM
            status = exit_.code
            raise
        finally:
            if arguments.run_log is not None:
                stage_argv = argv[argv.index(arguments.command):]  # without the root options (--run-log FILE)
                log_run(arguments.run_log, stage_argv, time.perf_counter() - start, status)
    return status


if __name__ == "__main__":
    sys.exit(main())
