"""The ``bplir`` command line.

Every sub-command accepts ``--preset NAME`` and ``--config FILE.toml``.  Bad
input (parameters, files, scenarios) prints one line ``bplir: error: ...``
to stderr and exits with status 2.
"""
from __future__ import annotations

from .common import InputError
from .main import main
from .parser import build_parser

__all__ = ["main", "build_parser", "InputError"]
