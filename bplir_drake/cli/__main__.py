"""``python -m bplir_drake.cli``: the ``bplir`` command."""
from .main import console

console()
