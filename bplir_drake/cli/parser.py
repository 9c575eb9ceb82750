"""The ``bplir`` argument parser: the root options and one sub-parser per
command, each declared by its command's module (``add_parser``)."""
from __future__ import annotations

import argparse

from ..io import package_version
from . import (benchmark_command, calibrate_command, commission_command, estimate_command,
               freeswing_command, model_command, montecarlo_command, observability_command,
               params_command, plan_command, qft_command, replay_command, swing_command,
               traverse_command)
from .common import _Parser

#: the commands in the order ``bplir --help`` lists them
COMMANDS = (model_command, params_command, freeswing_command, estimate_command,
            observability_command, swing_command, montecarlo_command, benchmark_command,
            traverse_command, plan_command, commission_command, calibrate_command, replay_command,
            qft_command)


def build_parser() -> argparse.ArgumentParser:
    """The ``bplir`` command line: one subcommand per job."""
    parser = _Parser(prog="bplir", description="Brachiating Power Line Inspection Robot tools")
    parser.add_argument("--version", action="version", version=f"bplir {package_version()}")
    parser.add_argument("--debug", action="store_true",
                        help="show the traceback of an unexpected fault")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    for command in COMMANDS:
        command.add_parser(sub)
    return parser
