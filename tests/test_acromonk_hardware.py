"""AcroMonk's hardware runs (examples/acromonk/, from DFKI's public
repository) reproduced from the command line only, as docs/robots.md shows:
its back-forth TVLQR swing by our closed loop on its URDF and plan, and its
ZF_pd log replayed into our plant beside Drake's AcrobotPlant."""
import json
from pathlib import Path

import numpy as np
import pytest

from test_hardening import bplir

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
HARDWARE = EXAMPLES / "acromonk"
LOG_COLUMNS = ("t=meas_time,q1=shoulder_meas_pos,q2=elbow_meas_pos,"
               "q1d=shoulder_meas_vel,q2d=elbow_meas_vel")


def _integration_residual(t, q, qd):
    """Largest gap (rad) between the angle and its rate integrated by the
    trapezoid rule -- a row mistyped in a transcription shows here."""
    steps = np.diff(t) * (qd[1:] + qd[:-1]) / 2
    return np.abs(q[0] + np.r_[0.0, np.cumsum(steps)] - q).max()


@pytest.mark.parametrize("name, columns, tolerance", [
    ("BF_plan.csv", ("time", "shoulder_pos", "elbow_pos", "shoulder_vel", "elbow_vel"), 0.01),
    ("BF_tvlqr_hardware.csv", ("meas_time", "shoulder_meas_pos", "elbow_meas_pos",
                               "shoulder_meas_vel", "elbow_meas_vel"), 0.05),
    ("ZF_pd_hardware.csv", ("meas_time", "shoulder_meas_pos", "elbow_meas_pos",
                            "shoulder_meas_vel", "elbow_meas_vel"), 0.01),
])
def test_the_shipped_runs_are_consistent(name, columns, tolerance):
    """Each joint's logged rate integrates to its logged angle (the plan to
    0.01 rad; the measured runs within their encoders' noise)."""
    data = np.genfromtxt(HARDWARE / name, delimiter=",", names=True)
    t = data[columns[0]]
    assert np.all(np.diff(t) > 0)
    for q, qd in ((columns[1], columns[3]), (columns[2], columns[4])):
        assert _integration_residual(t, data[q], data[qd]) < tolerance, (name, q)


def _bf_swing(out, *options):
    """``bplir swing`` of examples/acromonk_bf.toml against the BF_tvlqr
    hardware log from the start of its TVLQR (0.0987 s) to contact."""
    return bplir("swing", "--config", EXAMPLES / "acromonk_bf.toml", *options,
                 "--against", HARDWARE / "BF_tvlqr_hardware.csv", "--angles", "robot",
                 "--columns", LOG_COLUMNS, "--span", "0.0987,2.03", "--no-animation",
                 "--out", out)


@pytest.mark.slow
def test_the_back_forth_tvlqr_hardware_run_is_reproduced(tmp_path):
    """bplir swing on examples/acromonk_bf.toml (the URDF, the plan the
    hardware tracked, its LQR weights) against the hardware log from the
    start of TVLQR to contact: each joint within 0.13 rad RMSE over 1.8 s
    and more, and the bar caught within 0.1 s of the hardware's 1.92 s.  Its
    motor is not the BPLIR's: no voltage figures are printed for it."""
    rc, out, err = _bf_swing(tmp_path)
    assert rc == 0, err
    assert "motor: no voltage envelope (motor.envelope = false)" in out
    assert "winding voltage" not in out
    summary = json.loads((tmp_path / "summary.json").read_text())
    against = summary["against"]
    assert max(against["rmse_rad"]) <= 0.13, against
    assert against["duration_s"] > 1.8
    assert summary["outcome"] == "captured"
    assert abs(summary["swing_time_s"] - (2.02 - 0.0987)) < 0.1
    assert (tmp_path / "against.png").stat().st_size > 10_000


def test_the_hardwares_own_controller_model_reproduces_it_too(tmp_path):
    """The TVLQR the hardware ran was computed on a model without joint
    damping: with that as the controller's model and the damping left in
    the simulated robot, the run is still reproduced within 0.13 rad (the
    elbow, whose friction the controller no longer knows, at 0.124)."""
    rc, out, err = _bf_swing(tmp_path, "--no-plots", "--set", "friction.fv1=0", "--set", "friction.fv2=0",
                             "--set", "true_friction.fv1=0.044",
                             "--set", "true_friction.fv2=0.06", "--json")
    assert rc == 0, err
    summary = json.loads(out)
    assert summary["true_friction"]["fv2"] == 0.06 and summary["outcome"] == "captured"
    rmse = summary["against"]["rmse_rad"]
    assert max(rmse) <= 0.13 and rmse[1] > 0.1, rmse


def test_the_zf_pd_log_replayed_beside_drakes_acrobot(tmp_path):
    """bplir replay of ZF_pd's first 0.5 s (the measured elbow torque from
    rest): the package's model (centres of mass off the axes) leaves the
    log by 0.1 rad at 0.16 s, AcrobotPlant (on the axes) at 0.28 s, the two
    models up to 0.097 rad apart -- the elbow's friction and the off-axis
    masses at this size, not the integrator."""
    rc, out, err = bplir("replay", HARDWARE / "ZF_pd_hardware.csv",
                         "--config", EXAMPLES / "acromonk_bf.toml", "--span", "0,0.5",
                         "--acrobot", "--angles", "robot",
                         "--columns", LOG_COLUMNS + ",tau=elbow_meas_tau",
                         "--json", "--out", tmp_path)
    assert rc == 0, err
    r = json.loads(out)
    assert r["samples"] == 104
    assert r["divergence_time_s"] == pytest.approx(0.164, abs=0.01)
    assert r["acrobot"]["divergence_time_s"] == pytest.approx(0.285, abs=0.01)
    np.testing.assert_allclose(r["rmse_rad"], [0.0123, 0.0587], atol=0.002)
    np.testing.assert_allclose(r["acrobot"]["rmse_rad"], [0.0170, 0.0978], atol=0.002)
    assert r["acrobot"]["largest_difference_from_model_rad"] == pytest.approx(0.097, abs=0.005)
    assert (tmp_path / "replay.png").stat().st_size > 10_000
