"""What every result object of the analysis package offers.

A result is a dataclass of computed data with ``summary()`` (the JSON-ready
numbers), ``to_dict()`` (the same, what the command line writes),
``to_json()`` (strict JSON text: NaN and infinity become null) and ``plot(axes=None)``
(draws it, returns the matplotlib figure; :mod:`.plotting`), like
python-control's response objects.  Saving is the caller's job.
"""
from __future__ import annotations

from ..io import dumps_strict


class Result:
    """Mixin of the result dataclasses: ``to_dict`` from ``summary()``,
    ``to_json``; subclasses define ``summary`` and ``plot``."""

    def summary(self) -> dict:  # pragma: no cover - defined by every result
        """The JSON-ready numbers of this result."""
        raise NotImplementedError

    def to_dict(self) -> dict:
        """The JSON-ready summary of this result."""
        return self.summary()

    def to_json(self) -> str:
        """:meth:`to_dict` as strict JSON text (NaN and infinity as null)."""
        return dumps_strict(self.to_dict())

    def plot(self, axes=None):  # pragma: no cover - defined by every result
        """Draw this result on ``axes`` (new figure when None); returns the figure."""
        raise NotImplementedError
