import matplotlib

matplotlib.use("Agg", force=True)

import json

import pytest

from bplir_drake.params import preset


@pytest.fixture(scope="session")
def params():
    return preset("dissertation")


def parse_strict_json(text):
    """JSON that a parser rejecting NaN and Infinity accepts (hardening item 9)."""
    def reject(const):
        raise ValueError(f"non-strict JSON constant {const}")
    return json.loads(text, parse_constant=reject)


@pytest.fixture
def strict_json():
    """The strict JSON parser (:func:`parse_strict_json`)."""
    return parse_strict_json


def plugin_source(fault: str) -> str:
    """A plug-in controller's source: zero torque until 0.3 s, then the
    statement ``fault`` inside its calc (``time`` is imported)."""
    return ("import time\n"
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
            "    return Odd()\n")
