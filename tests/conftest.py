import matplotlib

matplotlib.use("Agg", force=True)

import dataclasses as dc
import json

import pytest

from bplir_drake.params import preset


@pytest.fixture(scope="session")
def params():
    return preset("dissertation")


def paced_48v(p):
    """``p`` at 48 V with its tries from hanging planned by guesses within
    85 % of the torque limit, on a pump whose torque alone uses at most 35 %
    of the driver's i^2 t budget where a guess gives one
    (plan.hanging_torque_share, plan.hanging_i2t_share; the shipped plans of
    the tests of those mechanisms are made so)."""
    p = p.with_hardware("48v")
    return p.with_(plan=dc.replace(p.plan, hanging_torque_share=0.85, hanging_i2t_share=0.35))


def parse_strict_json(text):
    """JSON that a parser rejecting NaN and Infinity accepts (hardening item 9)."""
    def reject(const):
        raise ValueError(f"non-strict JSON constant {const}")
    return json.loads(text, parse_constant=reject)


@pytest.fixture
def strict_json():
    """The strict JSON parser (:func:`parse_strict_json`)."""
    return parse_strict_json


def plugin_source(fault: str, factory: str = "pass") -> str:
    """A plug-in controller's source: zero torque until 0.3 s, then the
    statement ``fault`` inside its calc (``os``, ``sys`` and ``time`` are
    imported); ``factory``: a statement its factory runs first."""
    return ("import os, sys, time\n"
            "from pydrake.systems.framework import LeafSystem\n"
            "class Odd(LeafSystem):\n"
            "    def __init__(self):\n"
            "        super().__init__()\n"
            "        self.DeclareVectorInputPort('state', 4)\n"
            "        self.DeclareVectorOutputPort('torque', 1, self.calc)\n"
            "    def calc(self, context, out):\n"
            "        if context.get_time() > 0.3:\n"
            f"            {fault}\n"
            "        out.SetAtIndex(0, 0.0)\n"
            "def make(params):\n"
            f"    {factory}\n"
            "    return Odd()\n")
