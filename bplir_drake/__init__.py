"""bplir-drake: the Brachiating Power Line Inspection Robot in Drake."""
from .params import BplirParams, ParameterError, load_toml, preset

__version__ = "0.1.0"
__all__ = ["BplirParams", "ParameterError", "load_toml", "preset", "__version__"]
