"""The identification package's error type, importable without pydrake (the
command line catches it before any command's machinery is loaded)."""


class CalibrationError(ValueError):
    """A malformed or unusable calibration log, or a bad fit request."""
