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
            for n in ("torque", "current", "power", "tripped", "voltage")}
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


# ---------------------------------------------------------------- voltage envelope

def test_stall_torque_and_no_load_speed_reproduce_table_4_2():
    """At the datasheet's 48 V the model stalls at Table 4.2's 124 A and
    3.43 N m; at the 30 V supply the elbow's no-load speed is 14.7 rad/s."""
    from bplir_drake.systems.motor import no_load_speed, stall_torque

    p = MotorParams()
    assert 48.0 / p.resistance == pytest.approx(124.0, rel=1e-12)
    assert stall_torque(p, 48.0) == pytest.approx(3.43, rel=1e-12)
    assert no_load_speed(p, 30.0) == pytest.approx(14.66, abs=0.01)
    # at 15 A the supply runs out at 11.8 rad/s; the driver gives 0.98 of it
    assert no_load_speed(p, 30.0 - p.resistance * 15.0) == pytest.approx(11.82, abs=0.01)
    assert no_load_speed(p) == pytest.approx(0.98 * 30.0 / (p.km * 74.0), rel=1e-12)
    assert no_load_speed(p, 0.98 * 30 - p.resistance * 15.0) == pytest.approx(11.53, abs=0.01)


@pytest.mark.parametrize("speed", [6.0, 11.0, 13.0, -12.0])
def test_held_command_at_speed_gives_the_envelope_torque(speed):
    """A full command held with the elbow turning at ``speed`` settles at
    the torque the voltage can drive: kt (V_max - Km N q2')/R, clipped to
    the current limit; braking against the motion is not limited."""
    from bplir_drake.systems.motor import torque_window

    p = MotorParams()
    out = run_motor(20.0, 0.1, p, qd2=speed)
    expected = min(p.torque_per_amp * (p.max_voltage - p.km * 74.0 * speed) / p.resistance,
                   p.torque_per_amp * 15.0)
    assert out["torque"][-1] == pytest.approx(expected, rel=1e-6)
    assert torque_window(speed, p)[1] == pytest.approx(expected, rel=1e-9)
    # the winding voltage never exceeds what the driver can give
    assert np.all(np.abs(out["voltage"]) <= p.max_voltage + 1e-9)
    braking = run_motor(-20.0, 0.1, p, qd2=abs(speed))
    assert braking["torque"][-1] == pytest.approx(-p.torque_per_amp * 15.0, rel=1e-6)


def test_envelope_off_delivers_any_current_at_any_speed():
    p = MotorParams(envelope=False)
    out = run_motor(20.0, 0.1, p, qd2=20.0)
    assert out["torque"][-1] == pytest.approx(p.torque_per_amp * 15.0, rel=1e-6)


@pytest.mark.slow
def test_energy_balance_over_a_swing_closes():
    """Electrical energy in = copper loss + the gearbox and motor losses of
    (4.12)'s efficiencies + the robot's mechanical energy change + what
    friction took, over a driven swing, to 1 % of the electrical energy."""
    from bplir_drake.diagrams import build_free_swing
    from bplir_drake.params import BplirParams
    from bplir_drake.systems.plant import kinetic_energy, potential_energy

    params = BplirParams()
    times = [0.0, 0.4, 0.8, 1.2]
    built = build_free_swing(params, elbow_torque=(times, [15.0, -12.0, 18.0, 0.0]),
                             motor=True, log_period=0.01)
    sim = Simulator(built.diagram)
    ctx = sim.get_mutable_context()
    pctx = built.plant.GetMyMutableContextFromRoot(ctx)
    q0 = np.array([-0.33, -2.0])
    built.plant.SetPositions(pctx, q0)
    sim.get_mutable_integrator().set_target_accuracy(1e-8)
    sim.AdvanceTo(1.6)
    motor, fr = built.systems["motor"], built.systems["friction"]
    e = motor.energies(ctx)
    x = built.plant.GetPositionsAndVelocities(pctx)
    tp = params.simulated_plant
    d_mech = (kinetic_energy(x[:2], x[2:], tp) + potential_energy(x[:2], tp)
              - potential_energy(q0, tp))
    friction = fr.GetMyContextFromRoot(ctx).get_continuous_state_vector()[0]
    eta = params.motor.eta_g * params.motor.eta_m
    losses = e["mechanical_J"] * (1.0 / eta - 1.0)
    assert e["electrical_J"] > 20.0 and e["copper_J"] > 1.0   # driven hard
    assert e["mechanical_J"] == pytest.approx(d_mech + friction, rel=0.01)
    assert e["electrical_J"] == pytest.approx(e["copper_J"] + losses + d_mech + friction,
                                              rel=0.01)
