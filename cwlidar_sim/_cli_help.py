"""The command line's plumbing: the formatter, a command with its examples, the Dask options, the JSON printed.

Kept apart from :mod:`cwlidar_sim.cli` (the commands themselves) and as light: argparse, json, math and
textwrap only.
"""

from __future__ import annotations

import argparse
import json
import math
import textwrap

__all__: list = []  # private to the CLI


class _Formatter(argparse.RawDescriptionHelpFormatter):
    """Descriptions pre-wrapped by :func:`_command`, examples kept as written, one line per command."""

    def __init__(self, prog):
        super().__init__(prog, max_help_position=28)

    def add_argument(self, action):
        super().add_argument(action)
        if isinstance(action, argparse._SubParsersAction):
            # argparse measures the commands one indent shallower than it prints them, which would
            # push the help of the longest name (campaign-report) onto a line of its own
            self._action_max_length = max(self._action_max_length,
                                          max((len(a.dest) for a in action._get_subactions()), default=0)
                                          + self._current_indent + self._indent_increment)


def _command(sub, name, help, description, examples):
    """A subcommand whose ``--help`` ends with worked examples (``examples``: lines of shell)."""
    width = 78
    text = "\n\n".join(textwrap.fill(par, width) for par in description.split("\n\n"))
    epilog = "examples:\n" + "\n".join("  " + line for line in examples)
    return sub.add_parser(name, help=help, description=text, epilog=epilog, formatter_class=_Formatter)


#: Said wherever a command takes a Dask scheduler: what a scheduler can do to the machine that uses it.
_DASK_TRUST = ("Only use a Dask scheduler you trust, on a network you trust: it has no authentication by "
               "default, its workers run whatever they are sent, and results come back by pickle, which can run "
               "code when read.")


def _add_dask_options(p, dest, what):
    """``--dask`` and ``--scheduler`` (the same option, both spellings on every command) and ``--worker-timeout``."""
    names = ("--dask", "--scheduler") if dest == "dask" else ("--scheduler", "--dask")
    p.add_argument(*names, dest=dest, default=None, metavar="ADDRESS",
                   help=f"run {what} on this Dask scheduler (e.g. tcp://host:8786; a trusted one only, see "
                        f"above); default: locally")
    p.add_argument("--worker-timeout", type=float, default=None, metavar="SECONDS",
                   help="with a scheduler: longest wait for its first worker before the run, and longest time "
                        "without any worker during it (default 60); then a one-line error, the finished work "
                        "kept")


def _finite(obj):
    """``obj`` with every non-finite float as None (JSON has no NaN or infinity)."""
    if isinstance(obj, dict):
        return {k: _finite(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v) for v in obj]
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def _json(obj) -> str:
    """What a command prints for ``--json`` or as its summary: strict JSON (a NaN is null)."""
    return json.dumps(_finite(obj), indent=2, allow_nan=False,
                      default=lambda o: _finite(o.item()) if hasattr(o, "item") else str(o))  # numpy scalars
