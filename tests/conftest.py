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
