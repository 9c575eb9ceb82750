"""The swing diagram as a Drake user composes it: wired into a diagram of
their own through its input ports (a disturbance source, their own
estimator), simulated with a plain ``Simulator``, read by named output
ports; and the estimate output's timing against the true state."""
from pathlib import Path

import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import BasicVector, DiagramBuilder, LeafSystem
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from bplir_drake.analysis.swing import swing_diagram
from bplir_drake.diagrams import SWING_INPUTS, SWING_SIGNALS, estimate_times
from bplir_drake.params import BplirParams
from bplir_drake.systems.plant import mass_matrix
from bplir_drake.systems.state import RobotState

ROOT = Path(__file__).resolve().parents[1]


class Encoders(LeafSystem):
    """A user's estimator: the true state sampled every ``period`` (encoders
    on both joints), held between samples."""

    def __init__(self, period, x0):
        super().__init__()
        self.DeclareVectorInputPort("state", 4)
        s = self.DeclareDiscreteState(BasicVector(np.asarray(x0, dtype=float)))
        self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._sample)
        self.DeclareStateOutputPort("estimate", s)

    def _sample(self, context, discrete):
        discrete.set_value(self.get_input_port(0).Eval(context))


def _composed(p, torque):
    built = swing_diagram(p, external_torque=True, estimate_input=True)
    builder = DiagramBuilder()
    swing = builder.AddNamedSystem("swing", built.diagram)
    source = builder.AddSystem(ConstantVectorSource(np.asarray(torque, dtype=float)))
    encoders = builder.AddSystem(Encoders(p.controller.period, np.r_[built.q0, 0.0, 0.0]))
    builder.Connect(source.get_output_port(), swing.GetInputPort("external_torque"))
    builder.Connect(swing.GetOutputPort("true_state"), encoders.get_input_port(0))
    builder.Connect(encoders.GetOutputPort("estimate"), swing.GetInputPort("estimate"))
    return built, swing, builder.Build()


def test_a_users_source_and_estimator_wired_into_the_swing_diagram():
    """The external torque enters the plant's dynamics exactly (the change of
    the joints' accelerations at the start is M(q0)^-1 tau); with the
    user's encoders as the estimate the swing, run by a plain Simulator,
    captures; outputs are read by name with their signal names."""
    p = BplirParams()
    tau = np.array([0.7, -0.4])
    built, swing, diagram = _composed(p, tau)
    assert [swing.get_input_port(i).get_name() for i in range(swing.num_input_ports())] == \
        ["external_torque", "estimate"] == list(SWING_INPUTS)[:2]
    def accelerations(built, diagram):
        plant_context = built.plant.GetMyContextFromRoot(diagram.CreateDefaultContext())
        return built.plant.EvalTimeDerivatives(plant_context).CopyToVector()[2:]

    quiet_built, _, quiet = _composed(p, np.zeros(2))
    change = accelerations(built, diagram) - accelerations(quiet_built, quiet)
    q0 = np.asarray(built.q0)
    assert np.allclose(change, np.linalg.solve(mass_matrix(q0, p.simulated_plant), tau),
                       rtol=1e-9, atol=1e-12)
    assert np.abs(change).min() > 0.1
    diagram = quiet
    swing = diagram.GetSubsystemByName("swing")
    sim = Simulator(diagram)
    sim.get_mutable_integrator().set_target_accuracy(1e-6)
    sim.AdvanceTo(p.scenario.max_time)
    root = sim.get_context()
    status = quiet_built.systems["interlock"].status(root)
    assert status["outcome"] == "captured" and status["capture_speed_mps"] < 0.5
    true_state = swing.GetOutputPort("true_state").Eval(swing.GetMyContextFromRoot(root))
    assert len(true_state) == len(SWING_SIGNALS["true_state"]) == 4
    named = RobotState(true_state)   # the package's named view of a state
    assert tuple(named.get_fields()) == SWING_SIGNALS["true_state"]
    assert named.q2 == true_state[1] and abs(named.q1 - 0.33) < 0.05
    assert abs(swing.GetOutputPort("estimate").Eval(
        swing.GetMyContextFromRoot(root))[1] - true_state[1]) < 0.2


def test_the_estimate_output_estimates_the_state_at_the_tick_before_its_read():
    """Logged beside the true state at the same times (every 1 ms) the EKF's
    estimate output seems to err by a tenth of a radian in the fast elbow
    swing; against the true state at the time each value estimates
    (:func:`estimate_times`) the error is the filter's own (0.01 rad, as
    ``run_swing`` reports), and a tick either side is ten times worse."""
    p = BplirParams()
    built = swing_diagram(p)
    builder = DiagramBuilder()
    swing = builder.AddSystem(built.diagram)
    est = LogVectorOutput(swing.GetOutputPort("estimate"), builder, 0.001)
    true = LogVectorOutput(swing.GetOutputPort("true_state"), builder, 0.001)
    diagram = builder.Build()
    sim = Simulator(diagram)
    sim.get_mutable_integrator().set_target_accuracy(1e-6)
    sim.AdvanceTo(1.0)
    ctx = sim.get_context()
    t = est.FindLog(ctx).sample_times()
    e, x = est.FindLog(ctx).data().T, true.FindLog(ctx).data().T
    naive = np.abs(e[:, 1] - x[:, 1]).max()
    tx = true.FindLog(ctx).sample_times()
    T = p.controller.period
    errors = [np.abs(e[:, 1] - np.interp(estimate_times(t, T) + shift, tx, x[:, 1])).max()
              for shift in (-T, 0.0, T)]
    assert naive > 0.1 and errors[1] < 0.015 and min(errors[0], errors[2]) > 0.1, \
        (naive, errors)


def test_an_estimate_input_replaces_the_estimator_only():
    from bplir_drake.params import ParameterError

    with pytest.raises(ParameterError, match="estimate_input replaces the estimator"):
        swing_diagram(BplirParams(), estimate_input=True,
                      estimator="examples/my_estimator.py:make")


@pytest.mark.slow
def test_a_swing_shown_live_in_meshcat():
    """``run_swing(p, live=LiveView(...))`` (``bplir swing --meshcat``) serves
    Meshcat on this machine, draws the robot 30 times a simulated second,
    paces the swing at real time and leaves the swing as it is."""
    import time
    import urllib.request

    from bplir_drake.analysis.live import LiveView
    from bplir_drake.analysis.swing import run_swing

    p = BplirParams()
    view = LiveView(p.plant)
    try:
        assert view.url.startswith("http://localhost:")
        assert b"meshcat" in urllib.request.urlopen(view.url, timeout=10).read().lower()
        start = time.perf_counter()
        live = run_swing(p, live=view)
        wall = time.perf_counter() - start
        assert view.meshcat.HasPath("/drake/robot")
    finally:
        view.close()
    plain = run_swing(p)
    T = live.summary.swing_time_s
    assert live.summary.outcome == plain.summary.outcome == "captured"
    assert live.summary.capture_speed_mps == plain.summary.capture_speed_mps
    assert wall >= 0.95 * T and abs(view.frames - 30 * T) <= 2


@pytest.mark.slow
def test_a_traversal_drawn_live_in_meshcat_is_the_same_traversal():
    """``run_traverse(..., live=LiveView(...))`` (``bplir traverse --meshcat``)
    draws the line and its obstacles and every swing (30 frames a simulated
    second, here unpaced) and crosses the line as without the view."""
    from bplir_drake.analysis.live import LiveView
    from bplir_drake.analysis.traverse.line import load_line
    from bplir_drake.analysis.traverse.traversal import run_traverse

    p = BplirParams()
    line = load_line(ROOT / "examples" / "line_flat.toml")
    view = LiveView(p.plant, rate=0.0)
    try:
        live = run_traverse(line, p, live=view)
        assert view.meshcat.HasPath("/drake/scene/line/0")
        assert view.meshcat.HasPath(f"/drake/scene/obstacles/{len(line.obstacles) - 1}")
    finally:
        view.close()
    plain = run_traverse(line, p)
    swinging = sum(r["duration_s"] for r in plain.rows if r["kind"] == "swing")
    assert live.totals == plain.totals and live.success
    assert abs(view.frames - 30 * swinging) <= 2 * len(plain.rows)


@pytest.mark.slow
def test_meshcat_waits_for_a_browser_until_ctrl_c(tmp_path):
    """``swing --meshcat --wait``: once the swing's outputs are written the
    server still answers a browser; Ctrl-C then ends the command as done
    (exit 0). ``--wait`` alone is refused."""
    import re
    import signal
    import subprocess
    import sys
    import urllib.request

    from forked import bplir_forked

    rc, _, err = bplir_forked("swing", "--wait", "--out", tmp_path / "x")
    assert rc == 2 and "allowed only with --meshcat" in err
    proc = subprocess.Popen([sys.executable, "-m", "bplir_drake.cli", "swing", "--meshcat",
                             "--wait", "--no-animation", "--no-plots", "--out", tmp_path / "s"],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    said = []
    for line in proc.stderr:   # until the swing is done and the server waits
        said.append(line)
        if "Ctrl-C ends the command" in line:
            break
    url = re.search(r"stays at (\S+);", said[-1]).group(1)
    assert (tmp_path / "s" / "summary.json").exists() and proc.poll() is None
    assert b"meshcat" in urllib.request.urlopen(url, timeout=10).read().lower()
    proc.send_signal(signal.SIGINT)
    assert proc.wait(60) == 0, proc.stderr.read()
