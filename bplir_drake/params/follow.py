"""The settings that are rules in a robot's own units, and how they follow
another robot (:func:`follow`): the one place that says what a field is
worth on a robot that is not the one its default was chosen on.

A rule's field *follows* the robot when nobody gave it: a file or ``--set``
did not (``BplirParams.given``) and it still holds the reference robot's
value (the preset's, the robot its default was chosen on).  It then takes
the reference's value in the robot's units -- by its reach, link lengths,
time unit ``sqrt(L/g)``, torque unit ``m g L``, capture band or torque
limit.  Following is idempotent, so a robot read from TOML, built in
Python or given on the command line is derived alike, and a hardware
option's values (stated on the reference robot) are put in the robot's
units by the same factors (:func:`in_units`).
"""
from __future__ import annotations

import math
from dataclasses import fields, replace
from typing import Callable

#: the grip spacings of a robot and the depths at which its landing laws take over,
#: which follow its reach (l1 + l2) when a file gives other links
SPACING_FIELDS = {"scenario": ("grip_spacing",), "plan": ("warm_spacing",),
                  "traverse": ("grip_spacing", "spacing_min", "spacing_max"),
                  "landing": ("reach_depth", "landing_depth", "shoot_depth")}

#: how a landing setting follows the robot's time unit sqrt(L/g), by its unit:
#: the power of the ratio of time units it is multiplied by (times, rates,
#: gains and accelerations keep their value in the robot's own time; its
#: heights inside the capture band follow the gripper's, :data:`BAND_FIELDS`)
LANDING_TIME_POWERS = {"s": 1, "1/s": -1, "rad/s": -1, "rad/s^2": -2, "m s/rad": 1}

#: the heights and depths measured inside the gripper's capture band, by
#: block: the landing's aims, the shot's hold zone, the aim law's margin and
#: the reach's aim, and where a planned swing comes to rest below the line;
#: a gripper with another capture distance keeps their share of it
BAND_FIELDS = {"landing": ("shoot_height", "shoot_lift_height", "shoot_hold_depth",
                           "landing_margin", "reach_lift"),
               "plan": ("end_depth",)}

#: how the default robot's friction follows a robot given as a [plant] table
#: (its joints undescribed): the power of the torque unit's ratio kq and of
#: the time unit's kt each coefficient is multiplied by (Coulomb torques keep
#: their share of m g L, viscous ones their share at the robot's own rates)
FRICTION_POWERS = {"fv1": (1, 1), "fv2": (1, 1), "fc1": (1, 0), "fc2": (1, 0), "b": (0, -1)}

Rule = Callable[[object], object]


def robot_scales(plant) -> tuple[float, float]:
    """(time scale sqrt(L/g) s, torque scale m g L N m) of a robot (reach
    ``L = l1 + l2``, mass ``m = m1 + m2``): its own units, in which robots
    alike in shape swing alike."""
    L = plant.l1 + plant.l2
    return math.sqrt(L / plant.g), (plant.m1 + plant.m2) * plant.g * L


def rules(p, ref) -> dict[tuple[str, str], Rule]:
    """The fields of ``p`` that are rules in its units, each with the
    function giving its value on ``p`` from its value on the reference
    robot ``ref``: only the rules whose unit differs between the two."""
    out: dict[tuple[str, str], Rule] = {}
    plant, base = p.plant, ref.plant
    if (plant.l1, plant.l2) != (base.l1, base.l2):
        out.update(_link_rules(plant, base))
    if plant != base:
        out.update(_scale_rules(p, ref))
    band = p.gripper.capture_distance / ref.gripper.capture_distance
    if band != 1.0:
        out.update({(b, n): _times(band) for b, names in BAND_FIELDS.items() for n in names})
    limit = p.motor.torque_limit
    if limit != ref.motor.torque_limit:
        out[("controller", "torque_limit")] = lambda v: limit
        if plant == base:   # on the same robot the probe and the weight follow the limit
            k = limit / ref.motor.torque_limit
            out[("plan", "delay_probe")] = _times(k)
            out[("plan", "lqr_torque")] = _over(k ** 2)
    return out


def _times(k: float) -> Rule:
    return lambda v: v * k


def _over(k: float) -> Rule:
    return lambda v: v / k


def _link_rules(plant, base) -> dict[tuple[str, str], Rule]:
    """The IMUs keep their place along the links (their radii and the
    filter's l1 follow their link), and the grip spacings and take-over
    depths keep their share of the reach (:data:`SPACING_FIELDS`)."""
    k1, k2 = plant.l1 / base.l1, plant.l2 / base.l2
    k = (plant.l1 + plant.l2) / (base.l1 + base.l2)
    out = {("imu", "r1"): _times(k1), ("imu", "r2"): _times(k2),
           ("estimator", "r1"): _times(k1), ("estimator", "r2"): _times(k2),
           ("estimator", "l1"): lambda v: plant.l1}
    out.update({(b, n): (lambda v: round(v * k, 3)) for b, names in SPACING_FIELDS.items()
                for n in names})
    return out


def _scale_rules(p, ref) -> dict[tuple[str, str], Rule]:
    """The delay probe keeps its share of m g L, the tracking LQR's torque
    weight its value in units of 1/(m g L)^2 and its rate weights in units
    of sqrt(L/g)^2, the landing's times, rates and gains their value in
    units of sqrt(L/g) (:data:`LANDING_TIME_POWERS`; the shot's least stop
    times at least two controller periods); a robot no description file
    gives (a ``[plant]`` table: no joints) has the reference's friction in
    its units (:data:`FRICTION_POWERS`)."""
    (t0, q0), (t1, q1) = robot_scales(ref.plant), robot_scales(p.plant)
    kq, kt = q1 / q0, t1 / t0
    out = {("plan", "delay_probe"): _times(kq), ("plan", "lqr_torque"): _over(kq ** 2),
           ("plan", "lqr_state"): lambda w: (w[0], w[1], w[2] * kt ** 2, w[3] * kt ** 2)}
    period = p.controller.period
    for f in fields(ref.landing):
        power = LANDING_TIME_POWERS.get(f.metadata.get("unit", ""))
        if power is not None and not isinstance(getattr(ref.landing, f.name), bool):
            out[("landing", f.name)] = _times(kt ** power)
    for hold in ("shoot_min_time", "shoot_lift_min_time"):
        out[("landing", hold)] = lambda v: max(v * kt, 2 * period)
    if not p.robot.file:
        out.update({("friction", n): _times(kq ** a * kt ** b)
                    for n, (a, b) in FRICTION_POWERS.items()})
    return out


def follow(p, ref, given=None):
    """``p`` with every rule's field that nobody gave (not in ``given``,
    default ``p.given``, and still at ``ref``'s value) at ``ref``'s value
    in ``p``'s units (:func:`rules`)."""
    blocks = followed(p, ref, p.given if given is None else given)
    return replace(p, **blocks) if blocks else p


def followed(p, ref, given) -> dict:
    """The blocks of ``p`` (anything with the blocks as attributes) that
    :func:`follow` changes, followed."""
    blocks: dict[str, dict] = {}
    for (block, name), rule in rules(p, ref).items():
        value, base = getattr(getattr(p, block), name), getattr(getattr(ref, block), name)
        if f"{block}.{name}" in given or value != base:
            continue
        blocks.setdefault(block, {})[name] = rule(base)
    return {b: replace(getattr(p, b), **v) for b, v in blocks.items()}


def in_units(p, ref, block: str, values: dict) -> dict:
    """``values`` of ``block``'s fields, stated on the reference robot
    ``ref``, in ``p``'s units (a hardware option's settings; a field no
    rule governs keeps its value)."""
    table = rules(p, ref)
    return {n: table.get((block, n), lambda v: v)(v) for n, v in values.items()}
