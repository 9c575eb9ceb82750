import matplotlib

matplotlib.use("Agg", force=True)

import pytest

from bplir_drake.params import preset


@pytest.fixture(scope="session")
def params():
    return preset("dissertation")
