"""The machinery of parameter blocks: a field with its unit, range and one-line meaning, range checks, and the frozen block every parameter table is."""
from __future__ import annotations

import math
from dataclasses import field, fields, replace
from pathlib import Path
from typing import Any
from importlib.metadata import entry_points


INF = math.inf

#: the largest magnitude any field without a bound of its own may take, in
#: its SI unit: far above any robot's value, far below where the model's
#: products of masses, lengths and rates overflow
MAX_MAGNITUDE = 1e9

#: the heaviest link a line carries (kg): far above any brachiator built
#: (AcroMonk's 0.6 kg free link, the BPLIR's 3.2 kg gripper link)
MAX_MASS = 1000.0

#: the largest winding resistance of a motor (ohm; small motors' are ohms)
MAX_RESISTANCE = 1000.0


class ParameterError(ValueError):
    """A parameter, preset or parameter file is invalid (one-line message)."""


def _p(default, unit: str, lo: float = -MAX_MAGNITUDE, hi: float = MAX_MAGNITUDE, *,
       lo_open=False, hi_open=False, doc: str = "", integer: bool = False, off: str = ""):
    """A numeric field with unit and allowed range ``[lo, hi]`` (or open;
    by default within :data:`MAX_MAGNITUDE`); ``integer``: a whole number;
    ``off``: the name of the choice that turns what the number does off
    (the field then holds that name; a 0, its former spelling, reads as it)."""
    return field(default=default, metadata=dict(unit=unit, lo=lo, hi=hi,
                                                lo_open=lo_open, hi_open=hi_open,
                                                doc=doc, integer=integer, off=off))


def number_or(value, off_value: float = 0.0) -> float:
    """A field with an ``off`` choice as a number: ``off_value`` where it
    holds the choice's name (what the compiled laws and the plan keys read)."""
    return off_value if isinstance(value, str) else value


def _count(default: int, unit: str, lo: float = 0, hi: float = MAX_MAGNITUDE, *,
           doc: str = ""):
    """A whole number (samples, ticks) in ``[lo, hi]``; a float with no
    fraction (``500.0`` from a file) is taken as the whole number."""
    return _p(default, unit, lo, hi, doc=doc, integer=True)


def _positive(default, unit: str, *, doc: str = ""):
    """A numeric field that must be > 0 (a length, mass, period, ...)."""
    return _p(default, unit, 0, lo_open=True, doc=doc)


#: the longest link or sensor distance a two-link brachiator can have (m)
MAX_LENGTH = 10.0


def _length(default, *, doc: str = ""):
    """A length of the robot (m) in (0, MAX_LENGTH]."""
    return _p(default, "m", 0, MAX_LENGTH, lo_open=True, doc=doc)


def _fraction(default, *, doc: str = ""):
    """A dimensionless field in (0, 1] (an efficiency, a share)."""
    return _p(default, "", 0, 1, lo_open=True, doc=doc)


#: the entry-point groups under which installed packages register plug-ins
PLUGIN_GROUPS = {"controller": "bplir_drake.controllers", "estimator": "bplir_drake.estimators"}


def registered_plugins(kind: str | None = None) -> dict[str, str]:
    """The plug-ins installed packages register (entry points in
    :data:`PLUGIN_GROUPS`): name -> ``module:factory``, of one ``kind``
    (``"controller"``, ``"estimator"``) or of both."""

    kinds = PLUGIN_GROUPS if kind is None else {kind: PLUGIN_GROUPS[kind]}
    return {ep.name: ep.value for group in kinds.values() for ep in entry_points(group=group)}


def _is_plugin(spec) -> bool:
    """``spec`` has the form ``module:factory`` (the module may be a path) or
    is the name of a registered plug-in (:func:`registered_plugins`)."""
    if not isinstance(spec, str) or not spec:
        return False
    if ":" not in spec:
        return spec in registered_plugins()
    module, factory = spec.rsplit(":", 1)
    return bool(module) and factory.isidentifier()


def plugin_arguments(args) -> dict:
    """``("key=value", ...)`` as keyword arguments of a plug-in's factory:
    each value read as a whole number, a number, true/false or else text.
    A malformed entry raises :class:`ParameterError`."""
    out = {}
    if not isinstance(args, (tuple, list)):
        raise ParameterError(f"plug-in arguments {args!r} must be a list of 'key=value'")
    for item in args:
        key, sep, text = str(item).partition("=")
        if not sep or not key.strip().isidentifier():
            raise ParameterError(f"plug-in argument {item!r} must be key=value with key a "
                                 "Python name")
        text = text.strip()
        value: Any = {"true": True, "false": False}.get(text.lower(), text)
        if value is text:
            for kind in (int, float):
                try:
                    value = kind(text)
                    break
                except ValueError:
                    continue
        if isinstance(value, float) and not math.isfinite(value):
            raise ParameterError(f"plug-in argument {item!r} is not a finite number; allowed: "
                                 "a finite number, true/false or other text")
        out[key.strip()] = value
    return out


def plugin_name(spec: str) -> str:
    """A plug-in's own name from its ``module:factory`` spec: a file's stem
    (``path/to/my_controller.py:make`` -> ``my_controller:make``), a module
    as it is; a preset name unchanged."""
    if not _is_plugin(spec) or ":" not in spec:   # a preset or a registered name
        return spec
    module, factory = spec.rsplit(":", 1)
    if module.endswith(".py") or "/" in module or "\\" in module:
        module = Path(module).stem
    return f"{module}:{factory}"


def _range_text(md) -> str:
    lo, hi = md["lo"], md["hi"]
    left = "(" if md["lo_open"] or lo == -INF else "["
    right = ")" if md["hi_open"] or hi == INF else "]"
    unit = f" {md['unit']}" if md["unit"] else ""
    off = f" or '{md['off']}'" if md.get("off") else ""
    return f"{left}{lo:g}, {hi:g}{right}{unit}{off}"


def _validate_block(block, name: str) -> None:
    for f in fields(block):
        md = f.metadata
        value = getattr(block, f.name)
        if "lo" not in md:
            continue
        if md.get("off") and (value == md["off"] or (value == 0 and not isinstance(value, bool))):
            object.__setattr__(block, f.name, md["off"])   # 0: the choice's former spelling
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ParameterError(
                f"{name}.{f.name} = {value!r} is not a number; allowed range "
                f"{_range_text(md)}")
        if not math.isfinite(value):
            raise ParameterError(
                f"{name}.{f.name} = {value} is not finite; allowed range "
                f"{_range_text(md)}")
        if md.get("integer"):
            if value != int(value):
                raise ParameterError(f"{name}.{f.name} = {value:g} is not a whole number; "
                                     f"allowed whole numbers in {_range_text(md)}")
            object.__setattr__(block, f.name, int(value))
        lo, hi = md["lo"], md["hi"]
        bad_lo = value <= lo if md["lo_open"] else value < lo
        bad_hi = value >= hi if md["hi_open"] else value > hi
        if bad_lo or bad_hi:
            raise ParameterError(
                f"{name}.{f.name} = {value:g} is out of range; allowed "
                f"{_range_text(md)}")


class _Block:
    """Mixin: validation on construction, conversion to/from dicts."""

    _name = "block"

    def __post_init__(self):
        _validate_block(self, self._name)
        self._check()

    def _check(self) -> None:  # cross-field checks
        pass

    def _check_plugin(self) -> None:
        """The block's ``plugin`` spec and ``plugin_args`` (controller and
        estimator blocks)."""
        if not isinstance(self.plugin, str) or (self.plugin and not _is_plugin(self.plugin)):
            raise ParameterError(
                f"{self._name}.plugin = {self.plugin!r} must be 'module:factory' (a module "
                "name or a .py file, a colon, a function returning a Drake system) or the "
                "name of a registered plug-in")
        plugin_arguments(self.plugin_args)
        if self.plugin_args and not self.plugin:
            raise ParameterError(f"{self._name}.plugin_args are given without "
                                 f"{self._name}.plugin")

    def _one_of(self, name: str, allowed) -> None:
        """Refuse a text field whose value is not one of ``allowed``."""
        value = getattr(self, name)
        if value not in allowed:
            raise ParameterError(f"{self._name}.{name} = '{value}' is unknown; allowed: "
                                 + ", ".join(allowed))

    def as_dict(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    @classmethod
    def from_dict(cls, data: dict[str, Any], base=None):
        base = base if base is not None else cls()
        known = {f.name for f in fields(cls)}
        for key in data:
            if key not in known:
                raise ParameterError(
                    f"unknown parameter '{cls._name}.{key}'; allowed: "
                    + ", ".join(sorted(known)))
        values = {}
        for f in fields(cls):
            if f.name in data:
                v = data[f.name]
                if isinstance(getattr(base, f.name), tuple):
                    if not isinstance(v, list):
                        raise ParameterError(f"{cls._name}.{f.name} = {v!r} must be a list")
                    v = tuple(v)
                if "lo" in f.metadata and isinstance(v, int) and not isinstance(v, bool):
                    try:
                        v = float(v)
                    except OverflowError:   # a TOML integer of hundreds of digits
                        raise ParameterError(
                            f"{cls._name}.{f.name} = {str(v)[:12]}... ({len(str(v))} digits) "
                            f"is not a finite number; allowed range "
                            f"{_range_text(f.metadata)}") from None
                expected = type(getattr(base, f.name))
                if f.metadata.get("off"):   # a number or the off choice's name: checked as built
                    expected = None
                if expected is bool and not isinstance(v, bool):
                    raise ParameterError(
                        f"{cls._name}.{f.name} = {v!r} must be true or false")
                if expected is str and not isinstance(v, str):
                    raise ParameterError(
                        f"{cls._name}.{f.name} = {v!r} must be a string")
                values[f.name] = v
        return replace(base, **values)

    def describe(self) -> list[tuple[str, Any, str, str]]:
        """(name, value, unit, doc) rows for documentation and reports."""
        return [(f.name, getattr(self, f.name), f.metadata.get("unit", ""),
                 f.metadata.get("doc", "")) for f in fields(self)]
