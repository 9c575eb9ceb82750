"""The tracker's loop linearised at frozen times: ``A - B K(t)`` of the
LQR's model agrees with a finite difference of the loop's own vector field
(Drake's time derivatives under the tracker's law), and its mid-plan poles
are the ones the gains were designed to give."""
import numpy as np
import pytest

from bplir_drake.analysis.model.closed_loop import (closed_loop_derivative, closed_loop_poles,
                                                    linearize_closed_loop)
from bplir_drake.params import BplirParams
from bplir_drake.planning.solve import tracking_plan


@pytest.fixture(scope="module")
def plan_and_gains():
    return tracking_plan(BplirParams())


@pytest.mark.parametrize("share", [0.25, 0.5, 0.75])
def test_the_frozen_loop_is_the_finite_difference_of_the_loop(plan_and_gains, share):
    """At a quarter, half and three quarters of the plan: each column of
    ``A - B K`` within 1e-6 of the largest entry of a central difference of
    the closed loop's derivative (steps of 1e-6 of each state)."""
    plan, gains = plan_and_gains
    p, t = BplirParams(), share * plan.duration
    ss = linearize_closed_loop(p, t)
    x0 = np.asarray(gains.x0.value(t)).ravel()
    fd = np.zeros((4, 4))
    for j in range(4):
        h = 1e-6 * max(1.0, abs(x0[j]))
        e = np.zeros(4)
        e[j] = h
        fd[:, j] = (closed_loop_derivative(p, t, x0 + e)
                    - closed_loop_derivative(p, t, x0 - e)) / (2 * h)
    assert np.abs(fd - ss.A).max() <= 1e-6 * np.abs(ss.A).max()
    assert ss.state_labels == ["q1", "q2", "q1d", "q2d"] and ss.input_labels == ["elbow_torque"]
    # the loop without the feedback is the plant alone: K matters
    assert not np.allclose(ss.A, ss.A + ss.B @ np.asarray(gains.K.value(t)).reshape(1, 4))


def test_mid_plan_poles_and_their_course_along_the_plan(plan_and_gains, tmp_path):
    """Mid-plan the loop's poles are -73.1, -1.2 and -2.16 +/- 7.16j /s; the
    table of the course along the plan has a row per sample, and its figure
    draws (Agg)."""
    plan, _ = plan_and_gains
    lam = np.linalg.eigvals(linearize_closed_loop(BplirParams(), 0.5 * plan.duration).A)
    lam = lam[np.lexsort((lam.imag, lam.real))]
    assert lam == pytest.approx([-73.06, -2.16 - 7.16j, -2.16 + 7.16j, -1.20], abs=0.01)
    poles = closed_loop_poles(BplirParams(), samples=21)
    frame = poles.to_pandas()
    assert len(frame) == 21 and list(frame.columns)[:3] == ["t_s", "pole1_real", "pole1_imag"]
    assert poles.poles[10] == pytest.approx(lam, abs=1e-9)   # the same time, the same poles
    s = poles.summary()
    assert s["fastest_real_per_s"] < -1000 < s["slowest_real_per_s"]
    fig = poles.plot()
    fig.savefig(tmp_path / "poles.png")
    assert (tmp_path / "poles.png").stat().st_size > 10_000


def test_a_time_outside_the_plan_is_refused():
    with pytest.raises(ValueError, match="outside the plan"):
        linearize_closed_loop(BplirParams(), 99.0)


def test_drakes_linearize_on_the_swing_diagram_is_one_line_not_an_abort():
    """In a process of its own (Drake's check would stop it with SIGABRT):
    ``pydrake.systems.primitives.Linearize`` on the hybrid swing diagram
    raises one line naming what to use; on the plant with friction, which
    has continuous state only, it still linearises."""
    import subprocess
    import sys

    script = (
        "import numpy as np\n"
        "from bplir_drake.params import preset\n"
        "from bplir_drake.diagrams import build_plant_with_friction, build_swing\n"
        "from pydrake.systems.primitives import Linearize\n"
        "p = preset()\n"
        "b = build_plant_with_friction(p)\n"
        "ctx = b.diagram.CreateDefaultContext()\n"
        "b.diagram.get_input_port(0).FixValue(ctx, [0.0])\n"
        "print(Linearize(b.diagram, ctx, equilibrium_check_tolerance=1e9).A().shape)\n"
        "s = build_swing(p)\n"
        "Linearize(s.diagram, s.diagram.CreateDefaultContext())\n")
    run = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                         timeout=120)
    assert run.returncode == 1, (run.returncode, run.stderr[-500:])
    assert run.stdout.strip() == "(4, 4)"
    last = run.stderr.strip().splitlines()[-1]
    assert last.startswith("bplir_drake.diagrams.linearize_guard.HybridLinearizeError: "
                           "Linearize cannot take brachiation_swing: it is hybrid (10 "
                           "continuous states, 7 discrete state groups")
    assert "linearize_closed_loop(params, t)" in last
