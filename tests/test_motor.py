"""Motor and driver (4.12)-(4.14), Table 4.2."""
import numpy as np
import pytest
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder
from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

from bplir_drake.params import MotorParams
from bplir_drake.systems.motor import (MotorDriver, apply_deadband, current_to_duty_cycle,
                                       duty_cycle_to_current)


def run_motor(tau_cmd, duration, p=MotorParams(), qd2=0.0):
    b = DiagramBuilder()
    m = b.AddSystem(MotorDriver(p))
    cmd = b.AddSystem(ConstantVectorSource([tau_cmd]))
    st = b.AddSystem(ConstantVectorSource([0.0, 0.0, 0.0, qd2]))
    b.Connect(cmd.get_output_port(0), m.GetInputPort("torque_command"))
    b.Connect(st.get_output_port(0), m.GetInputPort("state"))
    logs = {n: LogVectorOutput(m.GetOutputPort(n), b, 0.001)
            for n in ("torque", "current", "power", "tripped")}
    d = b.Build()
    sim = Simulator(d)
    sim.AdvanceTo(duration)
    ctx = sim.get_context()
    out = {n: lg.FindLog(ctx).data()[0] for n, lg in logs.items()}
    out["t"] = logs["torque"].FindLog(ctx).sample_times()
    return out


def test_peak_current_cut_to_continuous_after_2_675_s():
    out = run_motor(25.0, 4.0)  # beyond the limit: 15 A requested
    t, i = out["t"], out["current"]
    assert i[(t > 0.05) & (t < 2.6)].min() == pytest.approx(15.0, abs=1e-3)
    t_cut = t[np.argmax(out["tripped"] > 0.5)]
    assert t_cut == pytest.approx(2.675, abs=0.015)
    assert i[t > t_cut + 0.05].max() == pytest.approx(5.0, abs=1e-3)


def test_current_time_constant_at_most_10_ms():
    out = run_motor(5.0, 0.1)
    i_final = 5.0 / MotorParams().torque_per_amp
    t63 = out["t"][np.argmax(out["current"] >= 0.632 * i_final)]
    assert t63 <= 0.010


@pytest.mark.parametrize("tau", [0.5, -0.8, 0.82])
def test_deadband_gives_zero_torque(tau):
    out = run_motor(tau, 0.2)
    assert np.abs(out["torque"]).max() == 0.0


def test_torque_never_exceeds_limit_and_power():
    for limit in (20.0, 15.0):
        p = MotorParams(torque_limit=limit)
        out = run_motor(100.0, 0.5, p, qd2=3.0)
        assert out["torque"].max() <= limit + 1e-9
        assert out["torque"][-1] == pytest.approx(limit if limit < 19.9 else p.torque_per_amp * 15,
                                                  rel=1e-3)
        np.testing.assert_allclose(out["power"], out["torque"] * 3.0)


def test_duty_cycle_map_4_13():
    np.testing.assert_allclose(duty_cycle_to_current([5, 10, 50, 90, 95]),
                               [0, 0, 7.5, 15, 15])
    np.testing.assert_allclose(duty_cycle_to_current(current_to_duty_cycle([0.5, 7.0, 14.0])),
                               [0.5, 7.0, 14.0])
    np.testing.assert_allclose(apply_deadband([0.5, 1.0, -0.9], 0.82336), [0, 1.0, -0.9])
