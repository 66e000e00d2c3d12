"""The ``nightloc`` command line: one sub-command per module in :mod:`nightloc.commands`.

Errors in the user's input (bad files, bad values) end the command with a one-line message on
stderr and exit status 2, never a traceback; set ``NIGHTLOC_DEBUG=1`` to see the traceback.
"""

from __future__ import annotations

import argparse
import importlib
import os
import sys
from typing import List, Optional

from . import __version__

# Sub-command modules; each defines register(subparsers) which adds its parser and sets
# `run=<function(args) -> int>` as a default.
COMMAND_MODULES = (
    "nightloc.commands.demo",
    "nightloc.commands.info",
    "nightloc.commands.build_map",
    "nightloc.commands.route",
    "nightloc.commands.synth",
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="nightloc",
        description="2D visual place recognition at night (Mount & Milford 2016) with a SIMD core.",
    )
    parser.add_argument("--version", action="version", version=f"nightloc {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    subparsers.required = True
    for name in COMMAND_MODULES:
        importlib.import_module(name).register(subparsers)
    return parser


def main(argv: Optional[List[str]] = None) -> int:
    """Entry point of the ``nightloc`` script; returns the exit status."""
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.run(args) or 0)
    except KeyboardInterrupt:
        print(f"nightloc {args.command}: interrupted", file=sys.stderr)
        return 130
    except (ValueError, TypeError, OSError, MemoryError) as error:
        if os.environ.get("NIGHTLOC_DEBUG"):
            raise
        message = str(error) or type(error).__name__
        print(f"nightloc {args.command}: error: {message}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
