"""The ``surrogacy`` console script: one subcommand per pipeline stage.

Each stage package keeps its own subcommands in a ``commands`` module with a ``register(subparsers)``
function; this file only collects them. ``surrogacy <stage> --help`` documents each one.
"""

from __future__ import annotations

import argparse
import importlib
import signal
import sys
import threading

STAGE_COMMANDS = ("geometry.commands", "fem.commands", "reduction.commands", "experiment.commands", "study.commands",
                  "study.discrepancy_commands")


def parser() -> argparse.ArgumentParser:
    """The argument parser with every stage subcommand."""
    root = argparse.ArgumentParser(prog="surrogacy", description=__doc__.splitlines()[0])
    subparsers = root.add_subparsers(dest="command", required=True, metavar="STAGE")
    for module_name in STAGE_COMMANDS:
        importlib.import_module(module_name).register(subparsers)
    return root


def terminate(signal_number, frame) -> None:
    """SIGTERM as a clean exit: the stage's ``finally`` blocks run (temporary files removed) before it ends."""
    raise SystemExit(128 + signal_number)


def main(argv: list[str] | None = None) -> int:
    """Run one stage; errors in the inputs print one clear line and exit with status 2; SIGTERM and Ctrl-C end it
    cleanly (no temporary file left) with 143 and 130."""
    arguments = parser().parse_args(argv)
    if threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGTERM, terminate)
    try:
        arguments.run(arguments)
    except (ValueError, OSError) as error:  # bad input, or a file or folder that cannot be read or written
        print(f"surrogacy {arguments.command}: error: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"surrogacy {arguments.command}: interrupted; finished results are kept, rerun to go on",
              file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
