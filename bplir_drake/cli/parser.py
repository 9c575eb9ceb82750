"""The ``bplir`` argument parser: the root options and one sub-parser per
command, each declared by its command's module (``add_parser``)."""
from __future__ import annotations

import argparse

from ..io import package_version
from . import (benchmark, calibrate, commission, estimate, freeswing, model, montecarlo, observability,
               parameters, plan, qft, replay, swing, traverse)
from .common import _Parser

#: the commands in the order ``bplir --help`` lists them
COMMANDS = (model, parameters, freeswing, estimate, observability, swing, montecarlo, benchmark,
            traverse, plan, commission, calibrate, replay, qft)


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
