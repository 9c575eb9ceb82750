"""System identification (4.5)-(4.7): calibration, dead-band, plant family."""
import dataclasses as dc
import json

import numpy as np
import pytest

from bplir_drake.analysis.identification import calibration as C
from bplir_drake.analysis.identification import deadband as DB
from bplir_drake.analysis.identification import fit as F
from bplir_drake.cli import main
from bplir_drake.params import around


@pytest.fixture(scope="module")
def true_friction(params):
    f = params.friction
    return dc.replace(f, fv1=f.fv1 * 1.2, fv2=f.fv2 * 0.8, fc1=f.fc1 * 0.8, fc2=f.fc2 * 1.2)


@pytest.mark.slow
def test_calibration_recovers_friction_within_5_percent(tmp_path, params, true_friction, capsys):
    """Synthetic Fig. 4.7 log: 8 s free swing + elbow square wave, friction
    of the logged robot changed by +/-20 %, 1 mrad angle noise.  Fitted
    through the CLI (CSV in, TOML out)."""
    log = C.synthetic_log(params.with_(true_friction=true_friction), free_time=8.0,
                          q0=(0.8, 0.0), noise=0.001)
    csv_path = C.write_calibration_csv(log, tmp_path / "log.csv")
    assert main(["calibrate", str(csv_path), "--out", str(tmp_path / "out"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for name, value in out["fitted"].items():
        assert value == pytest.approx(getattr(true_friction, name), rel=0.05), name
    # measured (dogbox, 85 simulations at 1e-5): fv1 -0.02 %, fv2 +0.02 %, fc1 +1.8 %, fc2 0.0 %
    assert out["rmse_before_rad"] > 0.1
    assert out["rmse_after_rad"] == pytest.approx(0.001, rel=0.1)   # the noise level
    # the written TOML is accepted by every command
    from bplir_drake.params import load_toml

    fitted = load_toml(out["toml"])
    assert fitted.friction.fc2 == pytest.approx(true_friction.fc2, rel=0.05)
    assert (tmp_path / "out" / "calibration.png").stat().st_size > 30_000


@pytest.mark.slow
def test_deadband_identified_within_5_percent(params):
    d = DB.identify_deadband(params)
    for side in ("forward", "reverse"):
        assert d[side] == pytest.approx(params.motor.deadband, rel=0.05)   # 0.8243 vs 0.8234
    wider = params.with_(motor=dc.replace(params.motor, deadband=1.2))
    assert DB.identify_deadband(wider, max_torque=2.0)["forward"] == pytest.approx(1.2, rel=0.05)


@pytest.mark.slow
def test_identified_family_contains_its_step_responses(params):
    fam = DB.identify_plant_family(params, n_plants=2)
    assert len(fam.fits) == 8
    inside = []
    for t, y, v in fam.responses:
        lo, hi = fam.envelope(t, v)
        inside.append(bool(np.all((y >= lo) & (y <= hi))))
    assert all(inside)
    assert fam.ranges["g"][0] > 0 and fam.ranges["Td"][1] < 0.05
    qf = fam.qft_family()
    assert len(qf) == 8
    # the fits are good: worst RMSE below 1 % of the largest motion
    worst = max(f["rmse"] / np.ptp(r[1]) for f, r in zip(fam.fits, fam.responses))
    assert worst < 0.01


def test_step_below_deadband_does_not_move(params):
    t, y = DB.cpfl_step_response(params, 5.0)   # a v = 0.64 N m < 0.82 N m
    assert np.abs(y).max() < 1e-9


HEADER = "t,q1,q2,tau\n"


@pytest.mark.parametrize("text, words", [
    ("t,q1,tau\n0,0,0\n", "lacks column(s) q2"),
    ("t,q1,q2\n0,0,0\n", "tau or i_cmd"),
    (HEADER + "".join(f"{k * 0.01},{0.1},{0.0},0\n" for k in range(15)), "too short"),
    (HEADER + "".join(f"{k * 0.005},{0.1},{0.0},0\n" for k in range(30)), "too short"),
    (HEADER + "".join(f"{k * 0.01},{0.1},{0.0},0\n" for k in range(400)), "no excitation"),
    (HEADER + "0,x,0,0\n", "non-numeric"),
    (HEADER + "-inf,0.1,0,0\n" + "".join(f"{k * 0.01},{0.1},{0.0},0\n" for k in range(1, 30))
     + "inf,0.1,0,0\n", "non-finite"),   # not "too short ... over nan s"
])
def test_bad_calibration_logs(tmp_path, text, words, capsys):
    f = tmp_path / "bad.csv"
    f.write_text(text)
    assert main(["calibrate", str(f), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith("bplir: error:") and err.count("\n") == 1 and words in err


def test_bad_fit_names(params):
    log = C.synthetic_log(params, free_time=2.0, torque_time=0.5, noise=0.0)
    with pytest.raises(C.CalibrationError, match="cannot fit mass3"):
        F.calibrate(params, log, ("mass3",))


@pytest.mark.slow
def test_a_small_robots_inertia_is_fitted_within_bounds_of_its_own_size():
    """Masses and inertias are fitted within 0.1x-10x their nominal values:
    a 0.34 m robot (DFKI's AcroMonk scale, I2 = 0.0017 kg m^2, below the
    former absolute floor of 0.01) recovers a 20 % heavier link-2 inertia
    from a synthetic log within 2 %."""
    import dataclasses as dc

    from bplir_drake.params import BplirParams, PlantParams

    plant = PlantParams(m1=0.63, m2=0.63, l1=0.34, l2=0.34, lc1=0.18, lc2=0.16,
                        I1=0.0017, I2=0.0017)
    nominal = around(plant)
    nominal = nominal.with_(friction=dc.replace(nominal.friction, fv1=0.002, fv2=0.002,
                                                fc1=0.0, fc2=0.0))
    truth = nominal.with_(true_plant=dc.replace(plant, I2=0.0017 * 1.2),
                          true_friction=nominal.friction)
    log = C.synthetic_log(truth, q0=(0.6, 0.2), free_time=2.0, torque=0.05, torque_time=2.0,
                          noise=0.0005)
    res = F.calibrate(nominal, log, ("I2",))
    assert res.values[0] == pytest.approx(0.0017 * 1.2, rel=0.02)


def test_a_logged_torque_replays_into_the_model(tmp_path, params, capsys):
    """``bplir replay``: a 1.2 s log (too short to calibrate on) of the
    model itself, replayed with its own torque through the CSV (9 digits),
    follows the log to 1e-6 rad (3e-10 measured) and never passes 0.1 rad;
    the log of a robot with 3x the elbow's viscous friction and -20 %
    link-2 inertia drifts away (31 / 77 mrad) and passes 0.1 rad at 0.96 s.
    The figure is drawn."""
    import dataclasses as dc

    same = C.synthetic_log(params, q0=(0.8, 0.2), free_time=0.4, torque=4.0, torque_time=0.8,
                           period=0.4, noise=0.0)
    csv_path = C.write_calibration_csv(same, tmp_path / "same.csv")
    assert main(["replay", str(csv_path), "--json", "--out", str(tmp_path / "a")]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["duration_s"] == pytest.approx(1.2) and out["divergence_time_s"] is None
    assert max(out["rmse_rad"]) < 1e-6
    assert (tmp_path / "a" / "replay.png").stat().st_size > 30_000
    other = params.with_(true_friction=dc.replace(params.friction, fv2=3 * params.friction.fv2),
                         true_plant=dc.replace(params.plant, I2=0.8 * params.plant.I2))
    drift = C.synthetic_log(other, q0=(0.8, 0.2), free_time=0.4, torque=4.0, torque_time=0.8,
                            period=0.4, noise=0.0)
    csv_path = C.write_calibration_csv(drift, tmp_path / "drift.csv")
    assert main(["replay", str(csv_path), "--json", "--out", str(tmp_path / "b")]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["divergence_time_s"] == pytest.approx(0.96, abs=0.05)
    assert max(out["rmse_rad"]) > 0.05
    assert main(["replay", str(csv_path), "--threshold", "-1", "--out", str(tmp_path / "c")]) == 2
    assert "--threshold = -1 rad is out of range" in capsys.readouterr().err


@pytest.mark.slow
def test_several_short_logs_fit_jointly_and_cross_validate(tmp_path):
    """Three 1.5 s logs of AcroMonk's links (examples/acromonk.toml) whose
    elbow friction is 40 % above the config's: fitted jointly from the
    command line, fv2 comes back within 3 %; left out in turn, each log's
    RMSE under the other two's fit falls at least fivefold; bounds are
    checked with one line."""
    import dataclasses as dc
    import json
    from pathlib import Path

    from bplir_drake.params import load_toml
    from test_hardening import assert_one_line_error, bplir

    cfg = Path(__file__).resolve().parents[1] / "examples" / "acromonk.toml"
    nominal = load_toml(cfg)
    truth = nominal.with_(true_friction=dc.replace(nominal.friction, fv2=0.084))
    paths = []
    for k, q0 in enumerate(((0.6, 0.2), (-0.4, 1.0), (0.2, -1.5))):
        log = C.synthetic_log(truth, q0=q0, free_time=0.5, torque=0.4, period=0.5,
                              torque_time=1.0, noise=0.0005, seed=k)
        paths.append(C.write_calibration_csv(log, tmp_path / f"log{k}.csv"))
    rc, out, err = bplir("calibrate", *paths, "--config", cfg, "--fit", "fv2", "--cv",
                         "--json", "--out", tmp_path / "cal")
    assert rc == 0, err
    res = json.loads(out)
    assert res["logs"] == 3 and res["fitted"]["fv2"] == pytest.approx(0.084, rel=0.03)
    for fold in res["cross_validation"]["folds"]:
        assert fold["held_out_rmse_after_rad"] < fold["held_out_rmse_before_rad"] / 5
    rc, _, err = bplir("calibrate", paths[0], "--config", cfg, "--fit", "I1", "--bounds", "2,10")
    assert_one_line_error(rc, err, "bounds = 2, 10", "allowed 0 < low < 1 < high")
    rc, _, err = bplir("calibrate", paths[0], "--config", cfg, "--cv")
    assert_one_line_error(rc, err, "--cv needs at least 2 logs")
