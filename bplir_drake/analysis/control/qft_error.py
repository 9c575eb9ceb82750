"""The control package's error type, importable without python-control
(the command line catches it; importing python-control takes 1.6 s)."""


class QftError(ValueError):
    """Bad family, specification or design (one-line message)."""
