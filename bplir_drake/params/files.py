"""Parameters in and out of files: TOML and plain dictionaries, with one-line errors naming the table and field."""
from __future__ import annotations

import os
import warnings

import tomllib
from dataclasses import replace
from pathlib import Path
from types import SimpleNamespace
from typing import Any
from .blocks import ParameterError
from .follow import followed
from .plan import split_path_table
from .model import BLOCKS, BplirParams, preset
from .retired import drop_retired
from .robot import RobotFileParams
from .robot_file import SHIPPED_ROBOTS, describe_robot, resolve_robot_file
from ..io import read_text, write_text_atomic


# ---------------------------------------------------------------- TOML
def from_dict(data: dict[str, Any], base: BplirParams | None = None,
              base_dir: Path | None = None) -> BplirParams:
    """Build parameters from a nested dict (as read from TOML).

    A top-level ``preset = "name"`` selects the base; every table overrides
    fields of the block of the same name.  A ``[robot]`` table naming a
    description file gives the ``[plant]`` block (a relative path from
    ``base_dir``); fields of a ``[plant]`` table override the file's.
    The settings that are rules in the robot's units and that the data do
    not give follow the robot from ``base``'s values
    (:func:`~.follow.follow`).
    """
    if not isinstance(data, dict):
        raise ParameterError("parameter data must be a table of tables")
    data = split_path_table(dict(data))   # files written before [plan] and [landing]
    data = drop_retired(data, BLOCKS)
    name = data.pop("preset", None)
    if name is not None and not isinstance(name, str):
        raise ParameterError(f"preset = {name!r} must be a string naming a preset")
    params = preset(name) if name else (base or preset("dissertation"))
    updates: dict[str, Any] = robot_file_updates(params, data, base_dir)
    for key, table in data.items():
        if key not in BLOCKS:
            raise ParameterError(
                f"unknown parameter table '[{key}]'; allowed: " + ", ".join(BLOCKS))
        if not isinstance(table, dict):
            raise ParameterError(f"'{key}' must be a table ([{key}]), got {table!r}")
        cls = BLOCKS[key]
        if key == "robot":
            continue   # robot_file_updates read it
        if key.startswith("true_"):
            current = getattr(params, key) or updates.get(key[len("true_"):],
                                                         getattr(params, key[len("true_"):]))
        else:
            current = updates.get(key, getattr(params, key))
        try:
            updates[key] = cls.from_dict(table, base=current)
        except ParameterError as exc:  # name the table the user wrote ([true_plant] ...)
            if key != cls._name:
                raise ParameterError(str(exc).replace(f"{cls._name}.", f"{key}.")) from None
            raise
        except TypeError as exc:  # pragma: no cover - defensive
            raise ParameterError(f"[{key}]: {exc}") from None
    plan = updates.get("plan")
    if plan is not None and plan.file and base_dir is not None and "file" in data.get("plan", {}):
        updates["plan"] = replace(plan, file=str((Path(base_dir) / plan.file).resolve()))
    given = params.given | {f"{b}.{n}" for b, names in given_fields(data).items()
                            for n in names if b in BLOCKS}
    blocks = SimpleNamespace(**{b: updates.get(b, getattr(params, b)) for b in BLOCKS})
    updates |= followed(blocks, params, given)   # the defaults that are rules in its units
    try:
        return replace(params, **updates, given=given)
    except TypeError as exc:  # pragma: no cover - defensive
        raise ParameterError(str(exc)) from None


def robot_file_updates(params: BplirParams, data: dict, base_dir: Path | None) -> dict:
    """``{"robot": ..., "plant": ...}`` when ``data``'s ``[robot]`` table
    names a description file (its path made absolute), else ``{}``."""
    table = data.get("robot")
    if not isinstance(table, dict) or not table:
        return {}
    robot = RobotFileParams.from_dict(table, base=params.robot)
    if not robot.file:
        return {"robot": robot}
    if robot.file not in SHIPPED_ROBOTS:
        robot = replace(robot, file=str(resolve_robot_file(robot.file, base_dir)))
    described = describe_robot(robot, base_dir)
    out = {"robot": robot, "plant": described.plant}
    given = given_fields(data).get("friction", set())
    damping = {n: d for n, d in zip(("fv1", "fv2"), described.damping)
               if d > 0.0 and n not in given}   # the file's joint damping: viscous friction
    if robot.file not in SHIPPED_ROBOTS:   # another robot: never the BPLIR's friction
        unknown = [n for n in ROBOT_FRICTION if n not in given and n not in damping]
        if unknown:
            warnings.warn(f"robot.file {robot.file} describes no {', '.join(unknown)}: taken "
                          "as 0 (the default robot's are not this robot's); give them in "
                          "[friction] or fit them with bplir calibrate", stacklevel=2)
        damping |= {n: 0.0 for n in unknown}
    if damping:
        out["friction"] = replace(params.friction, **damping)
    return out


#: the friction coefficients a robot's own description (its joint damping),
#: its config or a calibration gives; never carried over from the default robot
ROBOT_FRICTION = ("fv1", "fv2", "fc1", "fc2")


def given_fields(data: dict) -> dict[str, set]:
    """The fields each table of ``data`` gives, by block."""
    return {b: set(t) if isinstance(t, dict) else set() for b, t in data.items()}


def read_toml(path: str | Path, what: str = "parameter file", error=ParameterError) -> dict:
    """A TOML file as a dict; unreadable, binary, non-UTF-8 or malformed files
    raise ``error`` with a one-line message naming the file (a UTF-8 BOM is
    accepted)."""

    path = Path(path)
    text = read_text(path, what, error)
    try:
        doc = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"malformed TOML in {path}: {exc}") from None
    except RecursionError:   # the parser recurses once a level
        doc = None
    if doc is None or _depth(doc) > MAX_TOML_DEPTH:
        raise error(f"{what} {path} nests its tables and arrays deeper than "
                    f"{MAX_TOML_DEPTH} levels; allowed at most {MAX_TOML_DEPTH}")
    return doc


#: the deepest nesting of tables and arrays a file the package reads may
#: have (its files are tables of tables, a few levels deep)
MAX_TOML_DEPTH = 32


def _depth(doc) -> int:
    """How deep ``doc``'s tables and arrays nest (without recursing)."""
    deepest, todo = 0, [(doc, 1)]
    while todo:
        value, level = todo.pop()
        deepest = max(deepest, level)
        if deepest > MAX_TOML_DEPTH:
            break
        items = value.values() if isinstance(value, dict) else value
        todo += [(v, level + 1) for v in items if isinstance(v, (dict, list))]
    return deepest


def load_toml(path: str | Path) -> BplirParams:
    """Read a parameter file; errors name the file and the problem."""
    return from_dict(read_toml(path), base_dir=Path(path).parent)


def to_dict(params: BplirParams) -> dict[str, Any]:
    """The parameters as a dict of tables (a TOML document)."""
    out: dict[str, Any] = {"preset": params.preset_name}
    for key in BLOCKS:
        block = getattr(params, key)
        if block is not None:
            out[key] = block.as_dict()
    return out


def to_toml(params: BplirParams) -> str:
    """The parameters as TOML text."""
    import tomli_w

    return tomli_w.dumps(to_dict(params))


def relative_files(data: dict[str, Any], base_dir: str | Path) -> dict[str, Any]:
    """``data`` (tables by block) with its files (``robot.file``,
    ``plan.file``) relative to ``base_dir`` where they are absolute paths,
    as a file in ``base_dir`` reads them, so a results directory moves
    with the files it names."""
    out = dict(data)
    for block in ("robot", "plan"):
        table = out.get(block)
        name = table.get("file") if isinstance(table, dict) else None
        if isinstance(name, str) and Path(name).is_absolute():
            out[block] = table | {"file": os.path.relpath(name, Path(base_dir).resolve())}
    return out


def save_toml(params: BplirParams, path: str | Path) -> None:
    """Write the parameters as TOML at ``path`` (atomic), their files
    relative to its directory (:func:`relative_files`)."""
    import tomli_w

    write_text_atomic(path, tomli_w.dumps(relative_files(to_dict(params), Path(path).parent)))


def as_jsonable(params: BplirParams) -> dict[str, Any]:
    """The parameters as JSON-ready data (= :func:`to_dict`)."""
    return to_dict(params)
