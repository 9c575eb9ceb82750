"""Plans made elsewhere (plan.file): a swing tracks a plan from its CSV as
it tracks the same plan from memory, the robot file's joint angles map to
the package's, and a bad file is one line."""
import dataclasses as dc
from pathlib import Path

import numpy as np
import pytest

from bplir_drake.planning.solve import tracking_plan
from bplir_drake.planning.file import read_plan_file
from bplir_drake.params import ParameterError, RobotFileParams, load_toml
from bplir_drake.params.robot_file import describe_robot

from test_hardening import assert_one_line_error, bplir
from test_robot_file import _write

ACROMONK = Path(__file__).resolve().parents[1] / "examples" / "acromonk.toml"


def _csv(path, header, rows):
    np.savetxt(path, rows, delimiter=",", header=",".join(header), comments="")
    return path


def test_a_plan_from_its_csv_is_tracked_as_the_same_plan_in_memory(tmp_path):
    """AcroMonk's swing (examples/acromonk.toml, its shipped plan): the plan
    written to a CSV with other column names and tracked from it gives the
    swing of the plan from memory, every number within 1e-9."""
    from bplir_drake.analysis.swing.swing_runner import SwingRunner

    p = load_toml(ACROMONK)
    plan = tracking_plan(p)[0]
    names = ("time", "shoulder_pos", "elbow_pos", "shoulder_vel", "elbow_vel", "elbow_torque")
    path = _csv(tmp_path / "plan.csv", ("extra",) + names,
                np.c_[np.zeros(len(plan.times)), plan.times, plan.states, plan.torque])
    ext = p.with_(plan=dc.replace(p.plan, file=str(path), file_columns=names))
    read = read_plan_file(ext)
    assert np.array_equal(read.times, plan.times)
    assert np.array_equal(read.states, plan.states) and read.status == "external"
    runner = SwingRunner()
    a, b = runner.run(p, seed=1).summary, runner.run(ext, seed=1).summary
    numbers = [k for k, v in a.items() if isinstance(v, float)]
    for k in numbers:
        assert b[k] == pytest.approx(a[k], abs=1e-9, nan_ok=True), k


def test_a_plan_in_the_robot_files_joint_angles_is_mapped(tmp_path):
    """plan.file_angles = "robot": the file's angles (the description's
    joints, an elbow turning the other way) come back as the package's, its
    clock from 0."""
    robot = RobotFileParams(file=str(_write(tmp_path, "-1 0 0")), pivot_joint="pivot",
                            elbow_joint="elbow", free_gripper="hook2")
    d = describe_robot(robot)
    t = np.linspace(0.0, 1.0, 21)
    x = np.c_[0.5 * np.sin(t), -2.0 + t, 0.5 * np.cos(t), np.ones_like(t)]
    tau = 0.3 * np.sin(3 * t)
    path = _csv(tmp_path / "plan.csv", ("t", "q1", "q2", "q1d", "q2d", "tau"),
                np.c_[t + 5.0, d.to_file_state(x), d.sign2 * tau])
    p = load_toml(ACROMONK)
    p = p.with_(robot=robot, plan=dc.replace(p.plan, file=str(path), file_angles="robot"))
    read = read_plan_file(p)
    assert d.sign2 == -1.0
    assert np.allclose(read.states, x, atol=1e-12) and np.allclose(read.torque, tau, atol=1e-12)
    assert np.allclose(read.times, t, atol=1e-12)   # from 0, whatever the file's clock


def test_a_bad_plan_file_is_one_line(tmp_path):
    t = np.linspace(0.0, 1.0, 21)
    ok = np.c_[t, np.zeros((21, 4)), 0.1 * np.ones(21)]
    _csv(tmp_path / "cols.csv", ("t", "q1", "q2", "q1d", "q2d", "torque"), ok)
    rc, _, err = bplir("swing", "--config", ACROMONK, "--set", f"plan.file={tmp_path / 'cols.csv'}",
                       "--out", tmp_path / "o")
    assert_one_line_error(rc, err, "lacks column(s) tau")
    strong = ok.copy()
    strong[:, 5] = 5.0
    _csv(tmp_path / "strong.csv", ("t", "q1", "q2", "q1d", "q2d", "tau"), strong)
    rc, _, err = bplir("swing", "--config", ACROMONK, "--set",
                       f"plan.file={tmp_path / 'strong.csv'}", "--out", tmp_path / "o")
    assert_one_line_error(rc, err, "torque up to 5 N m", "controller.torque_limit = 3 N m")
    with pytest.raises(ParameterError, match="needs plan.file"):
        from bplir_drake.diagrams.swing_setup import start_state

        p = load_toml(ACROMONK)
        start_state(p.with_(scenario=dc.replace(p.scenario, start="plan")))


def test_a_swing_can_start_where_the_plan_starts(tmp_path):
    """scenario.start = "plan": the simulated robot starts in the plan
    file's first state, moving (a plan cut 0.2 s into AcroMonk's swing),
    and the filter starts believing it."""
    from bplir_drake.analysis.swing.swing_runner import SwingRunner

    p = load_toml(ACROMONK)
    plan = tracking_plan(p)[0]
    k = int(np.searchsorted(plan.times, 0.2))
    path = _csv(tmp_path / "cut.csv", ("t", "q1", "q2", "q1d", "q2d", "tau"),
                np.c_[plan.times[k:], plan.states[k:], plan.torque[k:]])
    q = p.with_(plan=dc.replace(p.plan, file=str(path)),
                scenario=dc.replace(p.scenario, start="plan"))
    res = SwingRunner().run(q, seed=0)
    state = res.logs["state"]
    assert np.abs(plan.states[k, 2:]).min() > 0.5   # moving
    assert np.allclose(state.data[0], plan.states[k], atol=1e-9)
    est = res.logs["estimate"]
    assert np.allclose(est.data[0], plan.states[k], atol=0.05)


@pytest.mark.slow
def test_a_log_in_the_robot_files_coordinates_replays_beside_drakes_acrobot(tmp_path):
    """bplir replay on a log written the way a robot's firmware writes it
    (its own column names, its joint angles, its clock): mapped to the
    package's angles the model replays the torque that made the log to
    1e-5 rad; Drake's AcrobotPlant with the same links but the centres of
    mass on the axes (it has no offset) leaves the log by 0.1 rad within
    0.5 s; read as the package's angles the log replays wrong; calibrate
    reads it with the same options."""
    import json

    from bplir_drake.analysis.identification import calibration as C

    _write(tmp_path)
    cfg = tmp_path / "small.toml"
    cfg.write_text('[robot]\nfile = "small.urdf"\npivot_joint = "pivot"\nelbow_joint = "elbow"\n'
                   'free_gripper = "hook2"\n[friction]\nfv1 = 0.044\nfv2 = 0.06\nfc1 = 0.0\n'
                   'fc2 = 0.0\n')
    p = load_toml(cfg)
    d = describe_robot(p.robot)
    t = np.arange(0.0, 3.0, 0.005)
    tau = 0.8 * np.sin(5 * t) * (t < 1.5)
    log = C.CalibrationLog(t, np.tile([0.2, -0.3], (len(t), 1)), tau, np.zeros(2))
    q = C.simulate_log(p, log, accuracy=1e-10)
    x = d.to_file_state(np.c_[q, np.zeros_like(q)])   # at rest at the start
    names = "meas_time,shoulder_pos,elbow_pos,shoulder_vel,elbow_vel,elbow_tau"
    _csv(tmp_path / "log.csv", names.split(","), np.c_[t + 10.0, x, d.sign2 * tau])
    cols = ("t=meas_time,q1=shoulder_pos,q2=elbow_pos,q1d=shoulder_vel,q2d=elbow_vel,"
            "tau=elbow_tau")
    rc, out, err = bplir("replay", tmp_path / "log.csv", "--config", cfg, "--columns", cols,
                         "--angles", "robot", "--acrobot", "--json", "--out", tmp_path / "r")
    assert rc == 0, err
    res = json.loads(out)
    assert max(res["rmse_rad"]) < 1e-5 and res["divergence_time_s"] is None
    assert res["acrobot"]["divergence_time_s"] < 0.5
    assert res["acrobot"]["largest_difference_from_model_rad"] > 0.1
    rc, out, err = bplir("replay", tmp_path / "log.csv", "--config", cfg, "--columns", cols,
                         "--json", "--out", tmp_path / "r2", "--span", "10.5,12")
    assert rc == 0 and json.loads(out)["samples"] == 301
    assert json.loads(out)["divergence_time_s"] is not None
    # calibrate reads the same log with the same options: the elbow's damping
    # set wrong is found again
    rc, out, err = bplir("calibrate", tmp_path / "log.csv", "--config", cfg, "--columns", cols,
                         "--angles", "robot", "--fit", "fv2", "--set", "friction.fv2=0.03",
                         "--json", "--out", tmp_path / "c")
    assert rc == 0, err
    assert json.loads(out)["fitted"]["fv2"] == pytest.approx(0.06, rel=0.01)
    rc, _, err = bplir("replay", tmp_path / "log.csv", "--columns", "t=meas_time,q9=x")
    assert_one_line_error(rc, err, "unknown name(s) q9", "allowed")
    rc, _, err = bplir("replay", tmp_path / "log.csv", "--columns", "t=clock")
    assert_one_line_error(rc, err, "no column(s) clock", "meas_time")


def test_our_plant_is_drakes_acrobot_when_the_centres_of_mass_are_on_axis():
    """The BPLIR's links with viscous friction only, a torque held over 5 ms
    samples for 2 s: our MultibodyPlant with its friction system and Drake's
    AcrobotPlant stay within 1e-6 rad (the integrator's steps at the
    torque's jumps; 1e-9 with the torque linear between samples)."""
    from bplir_drake.analysis.identification import calibration as C
    from bplir_drake.params import BplirParams

    p = BplirParams()
    p = p.with_(friction=dc.replace(p.friction, fc1=0.0, fc2=0.0))
    t = np.arange(0.0, 2.0, 0.005)
    log = C.CalibrationLog(t, np.tile([0.3, -0.5], (len(t), 1)), 3 * np.sin(4 * t),
                           np.array([0.5, 0.0]))
    for interpolation, tol in (("zoh", 1e-6), ("linear", 1e-9)):
        ours = C.simulate_log(p, log, accuracy=1e-8, interpolation=interpolation)
        drake = C.acrobot_log_angles(p, log, interpolation=interpolation)
        assert np.abs(ours - drake).max() < tol
        assert np.abs(ours - log.q).max() > 0.5   # it moved


@pytest.mark.slow
def test_a_swing_against_a_logged_run(tmp_path):
    """bplir swing --against: the swing of AcroMonk's example against a log
    of the same swing under the firmware's column names reproduces it to
    1e-6 rad; against another seed's swing the RMSE shows the difference,
    with a figure of both."""
    import csv
    import json

    rc, out, err = bplir("swing", "--config", ACROMONK, "--seed", "1", "--no-animation",
                         "--no-plots", "--out", tmp_path / "run")
    assert rc in (0, 1), err
    with open(tmp_path / "run" / "swing_log.csv") as f:
        rows = list(csv.DictReader(f))
    with open(tmp_path / "hw.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["meas_time", "shoulder_pos", "elbow_pos"])
        for r in rows:
            w.writerow([r["t"], r["q1"], r["q2"]])
    cols = "t=meas_time,q1=shoulder_pos,q2=elbow_pos"
    results = {}
    for seed in ("1", "0"):
        rc, out, err = bplir("swing", "--config", ACROMONK, "--seed", seed, "--no-animation",
                             "--against", tmp_path / "hw.csv", "--columns", cols, "--json",
                             "--out", tmp_path / f"s{seed}")
        assert rc in (0, 1), err
        results[seed] = json.loads(out)["against"]
    assert max(results["1"]["rmse_rad"]) < 1e-6 and results["1"]["duration_s"] > 1.5
    assert max(results["0"]["rmse_rad"]) > 1e-3
    assert (tmp_path / "s0" / "against.png").stat().st_size > 10_000
