"""The full closed-loop swing (chapters 7-8): outcomes, interlock, figures."""
import dataclasses as dc
import json
from concurrent.futures import ProcessPoolExecutor

import numpy as np
import pytest

from bplir_drake.plotting import save_figure
from bplir_drake.analysis.swing.swing_runner import run_swing
from bplir_drake.cli import main


@pytest.fixture(scope="module")
def default_swing(params):
    return run_swing(params)          # EKF in the loop, friction drawn +/-20 %, seed 0


def test_default_swing_is_captured(default_swing, params):
    s = default_swing.summary
    assert s["success"] and s["outcome"] == "captured"
    assert 1.0 <= s["swing_time_s"] <= 2.0          # the dissertation: ~1.5 s (sim), 1.25 s (lab)
    assert s["capture_speed_mps"] <= params.gripper.capture_speed
    assert s["capture_distance_m"] <= params.gripper.capture_distance
    assert s["peak_torque_Nm"] <= 20.0 + 1e-9
    assert s["fixed_gripper_open"]
    assert s["estimator_in_loop"] and s["max_estimation_error_rad"] < 0.02
    assert s["seed"] == 0 and s["thresholds"]["capture_speed_mps"] == 0.5
    # the friction of the simulated robot was drawn within +/-20 % of nominal
    for k in ("fv1", "fv2", "fc1", "fc2"):
        ratio = s["true_friction"][k] / getattr(params.friction, k)
        assert 0.8 <= ratio <= 1.2 and ratio != 1.0


def test_final_configuration_mirrors_the_start(default_swing, params):
    """(7.1): the gripper ends on the line at the mirror point (within the
    capture tolerance across the line, a few cm along it)."""
    s = default_swing.summary
    p = params.plant
    from bplir_drake.systems.plant import gripper_position

    x, y = gripper_position(s["final_configuration_rad"], p.l1, p.l2)
    assert abs(y) <= params.gripper.capture_distance
    assert abs(x - params.scenario.grip_spacing) < 0.06
    assert np.allclose(s["final_configuration_rad"], s["target_configuration_rad"], atol=0.06)


def _swing_outcome(seed):
    from bplir_drake.params import preset

    r = run_swing(preset(), seed=seed)
    s = r.summary
    return (seed, s["outcome"], s["capture_speed_mps"], s["peak_torque_Nm"],
            s["fixed_gripper_open"], s["swing_time_s"])


@pytest.mark.slow
def test_twenty_seeds_with_ekf_and_uncertain_friction():
    """The default robot (IMUs alone, 30 V) and controller (plan tracking,
    the shot, standstill calibration, the delay probe), friction drawn
    ±20 %.  Measured: all of seeds 0-19 captured at 0.137-0.323 m/s after
    1.347-1.366 s, peak torque 13.0-14.0 N m."""
    with ProcessPoolExecutor(2) as ex:
        rows = list(ex.map(_swing_outcome, range(20)))
    assert [r[0] for r in rows if r[1] != "captured"] == []
    for seed, outcome, speed, torque, fixed_open, t in rows:
        assert torque <= 20.0 + 1e-9
        assert fixed_open == (outcome == "captured")   # the interlock never opens early
        if outcome == "captured":
            assert 0.13 <= speed <= 0.33 and 1.34 <= t <= 1.37
        else:
            assert outcome == "crash" and speed > 0.5   # a fast arrival is never a success


def test_weak_motor_cannot_falsely_capture(params):
    """With 2 N m the path generator swings and does not capture.  (The
    default, plan tracking, refuses before it moves: "no feasible plan for a
    0 deg line within 2 N m and 220 W", a ParameterError; SNOPT takes about
    2 min to give up on its three initial guesses, so the suite leaves it.)"""
    p = params.with_(motor=dc.replace(params.motor, torque_limit=2.0),
                     controller=dc.replace(params.controller, torque_limit=2.0),
                     path=dc.replace(params.path, mode="adaptive"))
    r = run_swing(p)
    assert r.summary["outcome"] in ("timeout", "crash", "fault")
    assert not r.summary["success"] and not r.summary["fixed_gripper_open"]
    assert r.summary["peak_torque_Nm"] <= 2.0 + 1e-9


def test_fast_arrival_is_a_crash(params):
    """The lab firmware's law drives the elbow as hard as it can: with a
    motor that has no voltage limit it arrives at ~6 m/s, a crash; on the
    robot's 30 V supply the voltage runs out (the envelope holds the current
    back for 0.17 s) and the swing falls 14 cm short of the line."""
    from bplir_drake.params import ControllerParams

    p = params.with_(controller=ControllerParams.preset_named("lab"),
                     path=dc.replace(params.path, mode="lab"))
    r = run_swing(p.with_(motor=dc.replace(p.motor, envelope=False)))
    assert r.summary["outcome"] == "crash"
    assert r.summary["capture_speed_mps"] > 3.0 and r.summary["peak_voltage_V"] > 40.0
    assert not r.summary["success"] and not r.summary["fixed_gripper_open"]
    real = run_swing(p).summary
    assert real["outcome"] == "timeout" and real["closest_distance_m"] > 0.1
    assert real["peak_voltage_V"] == pytest.approx(29.4) and real["on_envelope_s"] > 0.1


def test_swing_cli_writes_figure_animation_log_summary(tmp_path, capsys):
    assert main(["swing", "--out", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    for key in ("success", "outcome", "swing_time_s", "capture_distance_m", "capture_speed_mps",
                "peak_torque_Nm", "peak_motor_power_W", "energy_in_J",
                "max_estimation_error_rad", "thresholds", "seed"):
        assert key in out
    assert out["success"]
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["parameters"]["plant"]["m1"] == 3.2287
    assert (tmp_path / "swing.png").stat().st_size > 50_000
    from PIL import Image

    with Image.open(tmp_path / "swing.gif") as gif:
        assert gif.n_frames >= 20 and gif.size[0] >= 300
    log = np.genfromtxt(tmp_path / "swing_log.csv", delimiter=",", names=True)
    assert log["t"][-1] == pytest.approx(out["swing_time_s"], abs=0.01)
    assert abs(log["gripper_y"][-1]) <= 0.02


@pytest.mark.parametrize("argv, words", [
    (["swing", "--incline", "90"], "scenario.incline_deg = 90 is out of range"),
    (["swing", "--preset", "nope"], "unknown preset 'nope'"),
    (["swing", "--controller", "pid"], "unknown controller preset 'pid'"),
])
def test_bad_scenarios_exit_2(argv, words, capsys):
    assert main(argv + ["--out", "/tmp/never-written"]) == 2
    err = capsys.readouterr().err
    assert err.startswith("bplir: error:") and err.count("\n") == 1 and words in err


@pytest.mark.parametrize("toml, words", [
    ("[scenario]\ngrip_spacing = 3.0\n", "grip_spacing = 3 m is out of reach"),
    ("[scenario\ngrip_spacing = 1.0\n", "malformed TOML"),
])
def test_bad_scenario_files_exit_2(tmp_path, toml, words, capsys):
    f = tmp_path / "s.toml"
    f.write_text(toml)
    assert main(["swing", "--config", str(f), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and words in err


@pytest.mark.slow
def test_compare_presets_and_examples(tmp_path, monkeypatch, params, capsys):
    from bplir_drake.analysis.swing.compare import compare_presets, comparison_table, plot_comparison

    rows = compare_presets(params)
    by = {r["variant"]: r for r in rows}
    assert by["plan (EKF)"]["outcome"] == "captured"
    assert by["plan (true state)"]["outcome"] == "captured"
    # measured (seed 0): the default's peak is near its delay probe's (13.9 and
    # 13.7 N m) on the estimate and on the true state; the path generator
    # brakes the elbow at the 19.9 N m the peak current gives (with the
    # swing's filter it lands 4 of seeds 0-7; seed 0 arrives at 0.54 m/s); the
    # published K crashes (1.3 m/s); the lab firmware's law runs out of
    # voltage and times out
    assert by["plan (EKF)"]["peak_torque_Nm"] < 14 and by["plan (true state)"]["peak_torque_Nm"] < 14
    assert by["plan's QFT loop, path generator (EKF)"]["peak_torque_Nm"] > 19
    assert by["cpfl-qft K=-216, F (EKF)"]["outcome"] == "crash"
    assert by["lab firmware (EKF)"]["outcome"] == "timeout"
    assert by["lab firmware (EKF)"]["peak_motor_power_W"] > 220   # beyond the rating
    assert comparison_table(rows).count("\n") == len(rows) + 1
    assert save_figure(plot_comparison(rows), tmp_path / "c.png").stat().st_size > 30_000
    # the examples run as written
    import runpy
    import pathlib

    ex = pathlib.Path(__file__).resolve().parents[1] / "examples"
    monkeypatch.chdir(tmp_path)
    runpy.run_path(str(ex / "custom_params.py"))
    main(["swing", "--no-animation", "--out", str(tmp_path / "out")])
    monkeypatch.setattr("sys.argv", ["x", str(tmp_path / "out" / "swing_log.csv")])
    runpy.run_path(str(ex / "plot_saved_log.py"))
    assert (tmp_path / "saved_log.png").stat().st_size > 10_000
    runpy.run_path(str(ex / "one_swing.py"))
    assert (tmp_path / "one_swing.png").stat().st_size > 30_000
    runpy.run_path(str(ex / "samples_in_context.py"))
    assert "diagrams built: 1" in capsys.readouterr().out


def _voltage_in_log(args):
    """(incline, seed, largest |voltage| of the written log, driver maximum,
    largest breach of the deliverable torque window, outcome)."""
    import tempfile

    from bplir_drake.analysis.swing.logs import write_log_csv
    from bplir_drake.params import preset

    incline, seed = args
    p = preset()
    p = p.with_(scenario=dc.replace(p.scenario, incline_deg=incline))
    res = run_swing(p, seed=seed)
    with tempfile.TemporaryDirectory() as d:
        path = write_log_csv(res, f"{d}/log.csv")
        names = path.read_text().splitlines()[0].split(",")
        log = np.loadtxt(path, delimiter=",", skiprows=1)
    col = {n: log[:, i] for i, n in enumerate(names)}
    m = p.motor
    # the voltage is the winding's: R i + Km N q2'
    np.testing.assert_allclose(col["voltage"], m.resistance * col["current"] + col["back_emf"],
                               atol=1e-4 * m.max_voltage)
    breach = max(float(np.max(col["torque"] - col["torque_available_hi"])),
                 float(np.max(col["torque_available_lo"] - col["torque"])))
    return (incline, seed, float(np.abs(col["voltage"]).max()), m.max_voltage, breach,
            res.summary["outcome"])


def test_default_robot_stays_within_the_driver_voltage():
    """Every swing log of the default robot (the 30 V supply, IMUs alone) at
    0, +20 and -20 deg, seeds 0-3: the winding voltage stays within the
    driver's largest output (0.98 x 30 V) and the delivered torque within
    the envelope at the logged elbow rate."""
    cases = [(a, s) for a in (0.0, 20.0, -20.0) for s in range(4)]
    with ProcessPoolExecutor(2) as ex:
        rows = list(ex.map(_voltage_in_log, cases))
    for incline, seed, peak, limit, breach, outcome in rows:
        assert limit == pytest.approx(29.4)
        assert peak <= limit * (1 + 1e-6), (incline, seed, peak)
        assert breach <= 1e-3 * 20.0, (incline, seed, breach)
        assert outcome == "captured", (incline, seed)
    # the uphill swing is the one that reaches the envelope
    assert max(r[2] for r in rows if r[0] == 20.0) > 27.0


def test_the_swing_diagram_composes_in_a_users_builder_and_runs_with_a_plain_simulator():
    """The swing diagram is a Drake system with named outputs; added to a
    user's ``DiagramBuilder`` and run by a plain ``Simulator`` (the runner's
    integrator settings) from its default context -- which holds the start
    pose and the sample -- it is the project's runner's swing to 1e-12."""
    from pydrake.systems.analysis import ResetIntegratorFromFlags, Simulator
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import LogVectorOutput

    from bplir_drake.analysis.swing.swing_runner import SWING_ACCURACY, swing_diagram
    from bplir_drake.diagrams.swing_ports import SWING_PORTS
    from bplir_drake.params import preset

    params = preset()
    built = swing_diagram(params, seed=3)
    builder = DiagramBuilder()
    swing = builder.AddSystem(built.diagram)
    assert [swing.get_output_port(i).get_name()
            for i in range(swing.num_output_ports())] == list(SWING_PORTS)
    log = LogVectorOutput(swing.GetOutputPort("true_state"), builder, 0.005)
    diagram = builder.Build()
    sim = Simulator(diagram)
    ResetIntegratorFromFlags(sim, "runge_kutta3", 0.01)
    sim.get_mutable_integrator().set_target_accuracy(SWING_ACCURACY)
    sim.AdvanceTo(params.scenario.max_time + 0.02)   # the interlock ends it at its decision
    mine = log.FindLog(sim.get_context())
    ref = run_swing(params, seed=3)
    assert ref.summary["outcome"] == "captured"
    t_ref, x_ref = ref.logs["state"].t, ref.logs["state"].data
    assert sim.get_context().get_time() == pytest.approx(t_ref[-1], abs=1e-12)
    n = min(len(t_ref), mine.sample_times().size)
    np.testing.assert_allclose(mine.data().T[:n], x_ref[:n], rtol=0, atol=1e-12)


def test_a_swing_draws_one_panel_on_one_axes(default_swing):
    """``result.plot(ax)`` with one axes draws one panel (the angles by
    default, or ``panel=``) with its limit labelled; a wrong panel is a
    ValueError naming the allowed ones."""
    from matplotlib.figure import Figure

    fig = Figure()
    ax = fig.subplots()
    assert default_swing.plot(ax) is fig and ax.get_ylabel() == "angle [rad]"
    fig = Figure()
    ax = fig.subplots()
    default_swing.plot(ax, panel="voltage")
    assert ax.get_ylabel() == "motor voltage [V]"
    assert any("driver limit" in t.get_text() for t in ax.texts)
    with pytest.raises(ValueError, match="allowed: angles, rates"):
        default_swing.plot(panel="wind")


def test_a_swings_logs_name_their_signals(default_swing):
    """Every log names its columns (one row per sample: Drake's VectorLog
    transposed); a named signal is its column, ``to_columns`` a table's
    columns with the times first; an unknown name says what the log has."""
    state = default_swing.logs["state"]
    assert state.names == ("q1", "q2", "q1d", "q2d") and state.data.shape == (len(state.t), 4)
    np.testing.assert_array_equal(state["q2"], state.data[:, 1])
    cols = default_swing.logs["imu"].to_columns()
    assert list(cols) == ["t", "gyro1", "gyro2", "acc1_x", "acc1_y", "acc2_x", "acc2_y"]
    assert all(len(v) == len(cols["t"]) for v in cols.values())
    with pytest.raises(KeyError, match="it has torque"):
        default_swing.logs["torque"]["current"]
    assert all(len(log.names) == log.data.shape[1] for log in default_swing.logs.values())
