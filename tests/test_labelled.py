"""Results as labelled arrays: a study over its samples with what each
drew as coordinates, a swing's logs and a plan's time series over time;
the numbers are the ones ``to_pandas()`` gives."""
import numpy as np
import pandas as pd
import pytest

from bplir_drake.analysis.montecarlo import Study, run_study


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    return run_study(Study(samples=3, seed=4), tmp_path_factory.mktemp("mc") / "mc", workers=1)


def test_a_study_round_trips_to_the_numbers_of_its_table(study):
    """``to_xarray()`` of a study: a ``sample`` dimension, the drawn
    friction coefficients and the seeds as coordinates, and every column
    of ``to_pandas()`` with the same values."""
    ds = study.to_xarray()
    frame = study.to_pandas()
    assert list(ds["sample"].values) == list(frame["index"])
    assert ds.attrs == {"root_seed": 4, "samples": 3}
    for name in ("seed", "true_friction.fv1", "true_friction.fc2"):
        assert name in ds.coords and ds[name].dims == ("sample",)
    back = ds.to_dataframe().reset_index().rename(columns={"sample": "index"})
    for col in frame.columns:
        a, b = frame[col].to_numpy(), back[col].to_numpy()
        if frame[col].dtype.kind == "f":
            assert np.array_equal(a, b.astype(float), equal_nan=True), col
        else:
            assert list(a) == list(b), col
    light = ds.where(ds["true_friction.fv1"] < ds["true_friction.fv1"].max(), drop=True)
    assert light.sizes["sample"] == 2   # selected by what was drawn


def test_a_plan_is_a_dataset_over_time():
    from bplir_drake.params import BplirParams
    from bplir_drake.planning.solve import tracking_plan

    plan, _ = tracking_plan(BplirParams())
    ds = plan.to_xarray()
    assert np.array_equal(ds["time"].values, plan.times)
    assert np.array_equal(ds["tau_Nm"].values, plan.torque)
    pd.testing.assert_frame_equal(ds.to_dataframe().reset_index(drop=True),
                                  plan.to_pandas().drop(columns="t_s"))
