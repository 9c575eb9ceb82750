"""Pendulum period (6.11)-(6.15) and the linearised hanging plant."""
import math

import numpy as np
import pytest

from bplir_drake.analysis.model.linearization import hanging_linearization
from bplir_drake.analysis.model.pendulum import com_radius, pendulum_periods


def test_T_min_as_published(params):
    per = pendulum_periods(params.plant)
    assert per.T_min_printed == pytest.approx(1.57, abs=0.01)
    # (6.14)'s radius is the straight robot (q2 = 0), the *largest* radius
    assert per.r_printed == pytest.approx(com_radius(params.plant, 0.0), rel=1e-12)
    assert com_radius(params.plant, math.pi) < per.r_printed
    assert per.T_folded == pytest.approx(1.03, abs=0.01)


def test_hanging_linearization_has_lightly_damped_stable_pair(params):
    lin = hanging_linearization(params)
    assert np.all(lin.eigenvalues.real < 0)
    osc = lin.eigenvalues[np.abs(lin.eigenvalues.imag) > 1e-6]
    assert len(osc) == 2
    wn, zeta = np.abs(osc[0]), -osc[0].real / np.abs(osc[0])
    assert 0.0 < zeta < 0.1
    # the elbow is held by the steep Coulomb slope at rest: the pair is the
    # compound pendulum with the elbow straight
    assert 2 * math.pi / wn == pytest.approx(pendulum_periods(params.plant).T_straight_compound,
                                             rel=0.02)


def test_linearization_without_friction_is_undamped(params):
    from bplir_drake.params import FrictionParams

    lin = hanging_linearization(params.with_(friction=FrictionParams(enabled=False)))
    assert np.abs(lin.eigenvalues.real).max() < 1e-9
    # small-oscillation frequencies of the free double pendulum: det(K - w^2 M) = 0
    from bplir_drake.systems.plant import mass_matrix

    p = params.plant
    M = mass_matrix([0, 0], p)
    Kg = np.array([[p.m1 * p.g * p.lc1 + p.m2 * p.g * (p.l1 + p.lc2), p.m2 * p.g * p.lc2],
                   [p.m2 * p.g * p.lc2, p.m2 * p.g * p.lc2]])
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(M, Kg)).real)
    np.testing.assert_allclose(np.sort(np.abs(lin.eigenvalues.imag))[::2], np.sqrt(w2),
                               rtol=1e-8)


def test_a_linearisation_is_a_named_python_control_state_space(params):
    """``Linearization.statespace()``: python-control's ``StateSpace`` with the
    state, input and output names, the same matrices and poles."""
    import control

    from bplir_drake.analysis.model.linearization import hanging_linearization

    lin = hanging_linearization(params)
    sys = lin.statespace()
    assert sys.state_labels == ["q1", "q2", "q1d", "q2d"]
    assert sys.input_labels == ["elbow_torque"] and sys.output_labels == sys.state_labels
    np.testing.assert_array_equal(sys.A, lin.A)
    np.testing.assert_allclose(np.sort_complex(control.poles(sys)),
                               np.sort_complex(lin.eigenvalues), rtol=1e-9)


def test_the_hanging_linearisation_without_coulomb_friction_is_the_closed_form(params):
    """``linearize_plant(coulomb=False)`` at rest: the double pendulum with
    its viscous joint friction, ``M s^2 + F s + K = 0`` (F = diag(fv1,
    fv2)), to 1e-8; without the Coulomb slope no pole is left faster than
    ten times sqrt(g/l1) (with it, the elbow's -382 /s)."""
    from bplir_drake.analysis.model.linearization import friction_poles, linearize_plant
    from bplir_drake.systems.plant import mass_matrix

    p, f = params.simulated_plant, params.simulated_friction
    lin = linearize_plant(params, coulomb=False)
    M = mass_matrix([0, 0], p)
    K = np.array([[p.m1 * p.g * p.lc1 + p.m2 * p.g * (p.l1 + p.lc2), p.m2 * p.g * p.lc2],
                  [p.m2 * p.g * p.lc2, p.m2 * p.g * p.lc2]])
    F = np.diag([f.fv1, f.fv2])
    A = np.block([[np.zeros((2, 2)), np.eye(2)],
                  [-np.linalg.solve(M, K), -np.linalg.solve(M, F)]])
    np.testing.assert_allclose(lin.A, A, rtol=1e-8, atol=1e-10)
    assert friction_poles(params, lin) is None
    assert friction_poles(params, linearize_plant(params)).startswith("the real pole(s) -382.4")
