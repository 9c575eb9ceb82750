"""A robot description checked for what a swing needs before Drake reads
it: every body's mass finite and positive, every inertia one a body can
have (finite, its principal moments non-negative and each at most the sum
of the other two), every pose and axis finite.

Drake's parser would otherwise go on with a warning and a substitute (a
mass of 1 kg, a unit inertia) and the robot simulated would not be the
robot described; a NaN in a pose fails deep inside the parser.  Each
problem is one :class:`ParameterError` line naming the file, the element
and the allowed range.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .blocks import ParameterError

#: how far an inertia may break the triangle inequality or be negative,
#: relative to its largest principal moment (a description's rounding)
INERTIA_SLACK = 1e-9

_URDF_INERTIA = ("ixx", "ixy", "ixz", "iyy", "iyz", "izz")


def check_description(path: Path) -> None:
    """Raise :class:`ParameterError` with one line on the first problem of
    the URDF or SDFormat file at ``path`` (a file that is not XML is left
    to Drake's parser, which names it)."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError):
        return
    if root.tag == "sdf":
        _check_sdf(path, root)
    else:
        _check_urdf(path, root)


def _numbers(path, where: str, text, counts=(1,)) -> np.ndarray:
    """``text`` as finite numbers (as many as one of ``counts``), or
    ParameterError naming ``where``."""
    try:
        values = np.array([float(v) for v in str(text).split()])
    except ValueError:
        values = np.zeros(0)
    if len(values) not in counts or not np.all(np.isfinite(values)):
        raise ParameterError(f"robot.file {path}: {where} = '{' '.join(str(text).split())}' is "
                             f"not {' or '.join(map(str, counts))} finite numbers")
    return values


def _check_mass(path, link: str, mass: float, inertia: np.ndarray) -> None:
    """A body's mass is finite and positive; 0 only for a massless frame
    (no inertia either: a hook's tip, a sensor's frame)."""
    massless = mass == 0.0 and not np.any(inertia)
    if not (math.isfinite(mass) and (mass > 0.0 or massless)):
        raise ParameterError(f"robot.file {path}: link '{link}' has mass {mass:g}"
                             + (" and an inertia" if mass == 0.0 else "")
                             + "; allowed: a finite mass > 0 kg (or 0 with no inertia: a "
                             "massless frame)")


def _check_inertia(path, link: str, moments: np.ndarray) -> None:
    """``moments`` (ixx, ixy, ixz, iyy, iyz, izz) must be a body's inertia."""
    ixx, ixy, ixz, iyy, iyz, izz = moments
    principal = np.linalg.eigvalsh(np.array([[ixx, ixy, ixz], [ixy, iyy, iyz], [ixz, iyz, izz]]))
    slack = INERTIA_SLACK * max(float(np.abs(principal).max()), 1e-300)
    a, b, c = principal
    if a < -slack or a + b < c - slack:
        raise ParameterError(
            f"robot.file {path}: link '{link}' has an inertia no body can have (principal "
            f"moments {a:.4g}, {b:.4g}, {c:.4g} kg m^2); allowed: each >= 0 and at most the "
            "sum of the other two")


def _check_links(path, root, sdf: bool) -> None:
    """Every link's inertial: URDF gives numbers as attributes (``<mass
    value=...>``, ``<inertia ixx=...>``), SDFormat as element text."""
    def text(element, key=None):
        if sdf:
            return (element.findtext(key) or "0") if key else (element.text or "")
        return element.get(key, "0") if key else element.get("value", "")

    for link in root.iter("link"):
        name = link.get("name", "?")
        for inertial in link.findall("inertial"):
            inertia = inertial.find("inertia")
            moments = np.zeros(6) if inertia is None else np.array([
                _numbers(path, f"link '{name}' inertia {k}", text(inertia, k))[0]
                for k in _URDF_INERTIA])
            mass = inertial.find("mass")
            if mass is not None:
                _check_mass(path, name, float(_numbers(path, f"link '{name}' mass",
                                                       text(mass))[0]), moments)
            _check_inertia(path, name, moments)


def _check_urdf(path, root) -> None:
    _check_links(path, root, sdf=False)
    for top in root:   # links, joints, ...: the poses and axes inside each
        owner = f"{top.tag} '{top.get('name', '?')}' "
        for element in top.iter():
            for attr in ("xyz", "rpy"):
                if attr in element.attrib:
                    _numbers(path, f"{owner}<{element.tag} {attr}>", element.get(attr), (3,))


def _check_sdf(path, root) -> None:
    _check_links(path, root, sdf=True)
    for element in root.iter():
        for tag, counts in (("pose", (6, 7)), ("xyz", (3,))):
            if element.tag == tag and (element.text or "").strip():
                _numbers(path, f"<{tag}>", element.text, counts)
