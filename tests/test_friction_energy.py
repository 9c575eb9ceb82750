"""Friction element (4.10)/(4.11), energy (7.8) and energy rate (7.13)."""
import math

import numpy as np
import pytest

from bplir_drake.analysis.model.freeswing import simulate_free_swing
from bplir_drake.analysis.model.friction_table import (friction_table, published_setup,
                                                 rmse_candidate)
from bplir_drake.params import FrictionParams
from bplir_drake.systems.friction import (JointFriction, joint_friction,
                                          joint_friction_discontinuous)


def test_candidate_approaches_reference_away_from_zero():
    v = np.array([-5.0, -0.5, 0.5, 5.0])
    ref = joint_friction_discontinuous(v, 0.0765, 0.7681, 0.02)
    cand = joint_friction(v, 0.0765, 0.7681, 0.01, 0.02)
    # 1 - (2/pi) atan(v/b) ~ 2b/(pi v): within 1.6 % of fc at 0.5 rad/s
    np.testing.assert_allclose(cand, ref, atol=0.7681 * 2 * 0.01 / (math.pi * 0.5) * 1.01)
    assert joint_friction(0.0, 0.0765, 0.7681, 0.01) == 0.0


def test_drag_opposes_motion():
    assert joint_friction(-3.0, 0.0, 0.0, 0.01, 0.1) == pytest.approx(-0.9)
    assert joint_friction(3.0, 0.0, 0.0, 0.01, 0.1) == pytest.approx(0.9)


def test_friction_system_converts_to_autodiff_and_symbolic():
    fr = JointFriction(FrictionParams())
    for conv in (fr.ToAutoDiffXd(), fr.ToSymbolic()):
        assert conv.num_input_ports() == 1
    ctx = fr.CreateDefaultContext()
    fr.get_input_port(0).FixValue(ctx, [0, 0, 1.0, -2.0])
    out = fr.get_output_port(0).Eval(ctx)
    assert out[0] == pytest.approx(-(0.1706 + 0.0124 * 2 / math.pi * math.atan(100)))
    assert out[1] == pytest.approx(-(-2 * 0.0765 - 0.7681 * 2 / math.pi * math.atan(200)))


def test_table_4_1_honest_rmse_over_40_rad_s(params):
    t = friction_table(params.friction.fc2, params.friction.b, 40.0)
    assert t.rmse_candidate == pytest.approx(0.0114, abs=0.0002)
    assert t.rmse_viscous == pytest.approx(0.7681, rel=1e-9)
    # the quadrature is converged: a brute-force fine grid agrees
    v = np.linspace(-40, 40, 4_000_001)
    e = 0.7681 * (np.sign(v) - 2 / np.pi * np.arctan(v / 0.01))
    assert math.sqrt(np.mean(e ** 2)) == pytest.approx(t.rmse_candidate, rel=2e-3)


def test_table_4_1_published_setup_reproduces_within_5_percent():
    pub = published_setup()
    assert pub.fc == 0.35
    assert 1.3 <= pub.vmax <= 1.6
    assert pub.rmse_candidate == pytest.approx(0.0272, rel=0.05)
    assert pub.rmse_viscous == pytest.approx(0.35, rel=0.05)
    # ... and over +/-40 rad/s the same fc gives a far smaller RMSE
    assert rmse_candidate(0.35, 0.01, 40.0) == pytest.approx(0.0052, abs=0.0002)


def test_energy_conserved_without_friction(params):
    r = simulate_free_swing(params, [0.8, 0.3], 20.0, friction=False, log_period=0.01)
    rel = np.abs(r.total - r.total[0]).max() / abs(r.total[0])
    assert rel < 1e-5
    assert np.ptp(r.x[:, 0]) > 1.0  # it really swung


def test_energy_decays_with_friction_and_rate_matches_7_13(params):
    r = simulate_free_swing(params, [0.8, 0.3], 20.0, friction=True)
    dE = np.diff(r.total)
    assert dE.max() < 1e-6                   # never increases beyond tolerance
    assert r.total[-1] < r.total[0] - 5.0    # and decays (9.2 J here)
    num = np.gradient(r.total, r.t)[5:-5]
    rate = r.energy_rate[5:-5]
    assert np.abs(num - rate).max() < 1e-3 * np.abs(rate).max()


def test_energy_rate_with_constant_torque(params):
    r = simulate_free_swing(params, [0.2, 0.0], 3.0, elbow_torque=4.0)
    num = np.gradient(r.total, r.t)[5:-5]
    assert np.abs(num - r.energy_rate[5:-5]).max() < 1e-3 * np.abs(r.energy_rate).max()
    # integrated power balance closes too
    E_int = np.concatenate([[0], np.cumsum(0.5 * (r.energy_rate[1:] + r.energy_rate[:-1])
                                           * np.diff(r.t))])
    assert np.abs(r.total - r.total[0] - E_int).max() < 1e-3
