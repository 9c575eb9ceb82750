"""``python -m bplir_drake.cli``: the ``bplir`` command."""
import sys

from .main import main

sys.exit(main())
