"""bplir-drake: the Brachiating Power Line Inspection Robot in Drake."""
from .io import package_version
from .params import BplirParams, ParameterError, load_toml, preset

__version__ = package_version()
__all__ = ["BplirParams", "ParameterError", "load_toml", "preset", "__version__"]
