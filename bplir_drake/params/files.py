"""Parameters in and out of files: TOML and plain dictionaries, with one-line errors naming the table and field."""
from __future__ import annotations

import math
import os
import warnings

import tomllib
from dataclasses import fields, replace
from pathlib import Path
from typing import Any
from .base import ParameterError
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
    updates = follow_the_links(params, updates, data)
    updates = follow_the_motor(params, follow_the_scales(params, updates, data), data)
    updates = follow_the_gripper(params, updates, data)
    plan = updates.get("plan")
    if plan is not None and plan.file and base_dir is not None and "file" in data.get("plan", {}):
        updates["plan"] = replace(plan, file=str((Path(base_dir) / plan.file).resolve()))
    try:
        return replace(params, **updates)
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


def follow_the_links(params: BplirParams, updates: dict, data: dict) -> dict:
    """When a file gives the robot other link lengths (``[plant]`` l1, l2)
    but not where its IMUs sit, the IMUs keep their place along the links:
    ``imu`` and ``estimator`` radii (and the filter's l1) scale with their
    link, so a shorter robot is not refused for the default 0.5 m radii.
    What the file gives itself is kept."""
    plant = updates.get("plant")
    if plant is None or (plant.l1, plant.l2) == (params.plant.l1, params.plant.l2):
        return updates
    k1, k2 = plant.l1 / params.plant.l1, plant.l2 / params.plant.l2
    given = given_fields(data)
    imu = updates.get("imu", params.imu)
    scaled = {n: getattr(params.imu, n) * k for n, k in (("r1", k1), ("r2", k2))
              if n not in given.get("imu", ())}
    est = updates.get("estimator", params.estimator)
    est_scaled = {n: v for n, v in (("r1", params.estimator.r1 * k1),
                                    ("r2", params.estimator.r2 * k2), ("l1", plant.l1))
                  if n not in given.get("estimator", ())}
    updates = updates | {"imu": replace(imu, **scaled), "estimator": replace(est, **est_scaled)}
    # the grip spacings and the landing laws' take-over depths keep their share of the reach
    k = (plant.l1 + plant.l2) / (params.plant.l1 + params.plant.l2)
    for block, names in SPACING_FIELDS.items():
        current = updates.get(block, getattr(params, block))
        spaced = {n: round(getattr(getattr(params, block), n) * k, 3) for n in names
                  if n not in given.get(block, ())}
        updates[block] = replace(current, **spaced)
    return updates


#: the grip spacings of a robot and the depths at which its landing laws take over,
#: which follow its reach (l1 + l2) when a file gives other links
SPACING_FIELDS = {"scenario": ("grip_spacing",), "plan": ("warm_spacing",),
                  "traverse": ("grip_spacing", "spacing_min", "spacing_max"),
                  "landing": ("reach_depth", "landing_depth", "shoot_depth")}


def robot_scales(plant) -> tuple[float, float]:
    """(time scale sqrt(L/g) s, torque scale m g L N m) of a robot (reach
    ``L = l1 + l2``, mass ``m = m1 + m2``): its own units, in which robots
    alike in shape swing alike."""
    L = plant.l1 + plant.l2
    return math.sqrt(L / plant.g), (plant.m1 + plant.m2) * plant.g * L


def follow_the_scales(params: BplirParams, updates: dict, data: dict) -> dict:
    """When a file gives another robot, the settings that are rules in the
    robot's own units keep their dimensionless value (what the file gives
    itself is kept): the delay probe's amplitude is the same share of the
    torque scale m g L, the tracking LQR's torque weight the same in units
    of 1/(m g L)^2 and its rate weights in units of sqrt(L/g)^2, and the
    landing's times, rates and gains the same in units of sqrt(L/g)
    (:data:`LANDING_TIME_POWERS`; its shot's least stop time at least two
    controller periods).  A robot given as a ``[plant]`` table, whose joints
    no description gives, has the default robot's friction in its own units
    (:data:`FRICTION_POWERS`) where the file gives none; a robot read from
    its own file has its own (:func:`robot_file_updates`)."""
    plant = updates.get("plant")
    if plant is None or plant == params.plant:
        return updates
    (t0, q0), (t1, q1) = robot_scales(params.plant), robot_scales(plant)
    kq, kt = q1 / q0, t1 / t0
    given = given_fields(data)
    plan, old = updates.get("plan", params.plan), params.plan
    scaled = {}
    if "delay_probe" not in given.get("plan", ()):
        scaled["delay_probe"] = old.delay_probe * kq
    if "lqr_torque" not in given.get("plan", ()):
        scaled["lqr_torque"] = old.lqr_torque / kq ** 2
    if "lqr_state" not in given.get("plan", ()):
        w = old.lqr_state
        scaled["lqr_state"] = (w[0], w[1], w[2] * kt ** 2, w[3] * kt ** 2)
    landing = updates.get("landing", params.landing)
    period = updates.get("controller", params.controller).period
    timed = {}
    for f in fields(params.landing):
        power = LANDING_TIME_POWERS.get(f.metadata.get("unit", ""))
        value = getattr(params.landing, f.name)
        if power is None or f.name in given.get("landing", ()) or isinstance(value, bool):
            continue
        timed[f.name] = value * kt ** power
    if "shoot_min_time" in timed:   # never shorter than two controller periods
        timed["shoot_min_time"] = max(timed["shoot_min_time"], 2 * period)
    out = updates | {"plan": replace(plan, **scaled), "landing": replace(landing, **timed)}
    robot = data.get("robot")
    if not (isinstance(robot, dict) and robot.get("file")):   # a [plant] table: no joints
        out["friction"] = _similar_friction(updates.get("friction", params.friction), kq, kt,
                                            given.get("friction", set()))
    return out


#: how the default robot's friction follows a robot given as a [plant] table
#: (its joints undescribed): the power of the torque unit's ratio kq and of
#: the time unit's kt each coefficient is multiplied by (Coulomb torques keep
#: their share of m g L, viscous ones their share at the robot's own rates)
FRICTION_POWERS = {"fv1": (1, 1), "fv2": (1, 1), "fc1": (1, 0), "fc2": (1, 0), "b": (0, -1)}


def _similar_friction(friction, kq: float, kt: float, given: set):
    """``friction`` (the default robot's) in another robot's units
    (:data:`FRICTION_POWERS`), the coefficients ``given`` kept."""
    return replace(friction, **{n: getattr(friction, n) * kq ** a * kt ** b
                                for n, (a, b) in FRICTION_POWERS.items() if n not in given})


#: how a landing setting follows the robot's time unit sqrt(L/g), by its unit:
#: the power of the ratio of time units it is multiplied by (times, rates,
#: gains and accelerations keep their value in the robot's own time; its
#: heights inside the capture band follow the gripper's, :data:`BAND_FIELDS`)
LANDING_TIME_POWERS = {"s": 1, "1/s": -1, "rad/s": -1, "rad/s^2": -2, "m s/rad": 1}


#: the heights and depths measured inside the gripper's capture band, by
#: block: the landing's aims, the shot's hold zone, the aim law's margin and
#: the reach's aim, and where a planned swing comes to rest below the line
#: (a swing's and a traversal's); a gripper with another capture distance
#: keeps their share of it
BAND_FIELDS = {"landing": ("shoot_height", "shoot_lift_height", "shoot_hold_depth",
                           "landing_margin", "reach_lift"),
               "plan": ("end_depth",), "traverse": ("plan_end_depth",)}


def follow_the_gripper(params: BplirParams, updates: dict, data: dict) -> dict:
    """When a file gives the gripper another capture distance, the heights
    inside the band (:data:`BAND_FIELDS`) keep their share of it; what the
    file gives itself is kept."""
    gripper = updates.get("gripper")
    if gripper is None or gripper.capture_distance == params.gripper.capture_distance:
        return updates
    k = gripper.capture_distance / params.gripper.capture_distance
    given = given_fields(data)
    out = dict(updates)
    for block, names in BAND_FIELDS.items():
        base, current = getattr(params, block), updates.get(block, getattr(params, block))
        out[block] = replace(current, **{f: getattr(base, f) * k for f in names
                                         if f not in given.get(block, ())})
    return out


def follow_the_motor(params: BplirParams, updates: dict, data: dict) -> dict:
    """When a file gives the motor another torque limit but not the
    controller's, the controller saturates at the motor's; on the same
    robot the delay probe (half the limit by default) and the tracking
    LQR's torque weight follow the limit (on another robot they follow its
    scales, :func:`follow_the_scales`)."""
    motor = updates.get("motor")
    if motor is None or motor.torque_limit == params.motor.torque_limit:
        return updates
    given = given_fields(data)
    out = dict(updates)
    if "torque_limit" not in given.get("controller", ()):
        out["controller"] = replace(updates.get("controller", params.controller),
                                    torque_limit=motor.torque_limit)
    if updates.get("plant", params.plant) != params.plant:
        return out
    k = motor.torque_limit / params.motor.torque_limit
    plan = updates.get("plan", params.plan)
    if "delay_probe" not in given.get("plan", ()):
        plan = replace(plan, delay_probe=params.plan.delay_probe * k)
    if "lqr_torque" not in given.get("plan", ()):   # the same weight on a torque's share
        plan = replace(plan, lqr_torque=params.plan.lqr_torque / k ** 2)
    return out | {"plan": plan}


def read_toml(path: str | Path, what: str = "parameter file", error=ParameterError) -> dict:
    """A TOML file as a dict; unreadable, binary, non-UTF-8 or malformed files
    raise ``error`` with a one-line message naming the file (a UTF-8 BOM is
    accepted)."""

    path = Path(path)
    text = read_text(path, what, error)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise error(f"malformed TOML in {path}: {exc}") from None


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
