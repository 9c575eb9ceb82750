"""Benchmark: simulated seconds per wall second of the default closed-loop
swing (EKF in the loop) and of the plant-only free swing, in one run, and
where the time of the closed loop goes.

Run: python benchmarks/bench_swing.py [SEEDS]   (default 10; prints figures,
not a test).  Goal (issue 14): >= 20 simulated s per wall s for the closed
loop (30 the stretch).  It also prints the ceiling of that figure: the
closed loop's C++ part alone, with every Python system of the 100 Hz chain
taken out and the commands replayed (:func:`cpp_ceiling`).
"""
import collections
import functools
import sys
import time

import numpy as np


class _PeerPlant:
    """An acrobot written the way the peer writes its plant: a method per
    matrix of the equations of motion (each copying the state it reads,
    numpy's scalar functions), viscous and Coulomb friction per joint in a
    loop, the mass matrix inverted every call, both joints' torques as a
    vector through the actuation matrix (the elbow's alone acts)."""

    def __init__(self, p):
        pl, fr = p.plant, p.friction
        self.m, self.l, self.com = [pl.m1, pl.m2], [pl.l1, pl.l2], [pl.rc1, pl.rc2]
        self.I, self.g = [pl.I1 + pl.m1 * pl.rc1 ** 2, pl.I2 + pl.m2 * pl.rc2 ** 2], pl.g
        self.b, self.cf = [fr.fv1, fr.fv2], [fr.fc1, fr.fc2]
        self.B = np.array([[0.0, 0.0], [0.0, 1.0]])

    def mass_matrix(self, x):
        pos = np.copy(x[:2])
        h = self.m[1] * self.l[0] * self.com[1] * np.cos(pos[1])
        m00 = self.I[0] + self.I[1] + self.m[1] * self.l[0] ** 2.0 + 2 * h
        m01 = self.I[1] + h
        return np.array([[m00, m01], [m01, self.I[1]]])

    def coriolis_matrix(self, x):
        pos, vel = np.copy(x[:2]), np.copy(x[2:])
        h = self.m[1] * self.l[0] * self.com[1] * np.sin(pos[1])
        return np.array([[-2 * h * vel[1], -h * vel[1]], [h * vel[0], 0.0]])

    def gravity_vector(self, x):
        pos = np.copy(x[:2])
        s1, s12 = np.sin(pos[0]), np.sin(pos[0] + pos[1])
        return np.array([-(self.m[0] * self.com[0] + self.m[1] * self.l[0]) * self.g * s1
                         - self.m[1] * self.g * self.com[1] * s12,
                         -self.m[1] * self.g * self.com[1] * s12])

    def coulomb_vector(self, x):
        vel = np.copy(x[2:])
        F = np.zeros(2)
        for i in range(2):
            F[i] = self.b[i] * vel[i] + self.cf[i] * np.arctan(100 * vel[i])
        return F

    def rhs(self, t, x, tau):
        vel = np.copy(x[2:])
        M, C = self.mass_matrix(x), self.coriolis_matrix(x)
        G, F = self.gravity_vector(x), self.coulomb_vector(x)
        acc = np.linalg.inv(M).dot(G + self.B.dot(tau) - C.dot(vel) - F)
        res = np.zeros(4)
        res[0], res[1], res[2], res[3] = x[2], x[3], acc[0], acc[1]
        return res

    def energy(self, x):
        M = self.mass_matrix(x)
        vel = np.copy(x[2:])
        pos = np.copy(x[:2])
        y1 = -self.com[0] * np.cos(pos[0])
        y2 = -self.l[0] * np.cos(pos[0]) - self.com[1] * np.cos(pos[0] + pos[1])
        return 0.5 * vel.dot(M.dot(vel)) + self.g * (self.m[0] * y1 + self.m[1] * y2)


def reference_loop_rate(duration: float = 10.0, dt: float = 0.002) -> float:
    """Simulated s per wall s of the kind of loop the DFKI double_pendulum
    simulator runs, written here in plain NumPy (:class:`_PeerPlant`):
    fixed-step RK4 at ``dt`` on the BPLIR's nominal acrobot; every step an
    energy-shaping collocated partial feedback linearisation (PFL) and an
    LQR about the upright state (its gain from Drake) are both evaluated
    and one is chosen by the distance to the upright state; the torque
    vector clipped to the limits; time, state and torque recorded in lists;
    each controller call recorded, filtered and compensated as the peer's
    controllers do (:func:`control`).  No estimator, sensors, motor or
    events: the same-run yardstick of the closed loop's rate."""
    from pydrake.systems.controllers import LinearQuadraticRegulator

    from bplir_drake.params import preset

    p = preset()
    plant = _PeerPlant(p)
    limit = np.array([0.0, p.motor.torque_limit])
    up, eps = np.array([np.pi, 0.0, 0.0, 0.0]), 1e-6
    A = np.column_stack([(plant.rhs(0, up + eps * e, np.zeros(2))
                          - plant.rhs(0, up - eps * e, np.zeros(2))) / (2 * eps)
                         for e in np.eye(4)])
    Bl = ((plant.rhs(0, up, np.array([0.0, eps])) - plant.rhs(0, up, np.array([0.0, -eps])))
          / (2 * eps)).reshape(4, 1)
    K, _ = LinearQuadraticRegulator(A, Bl, np.diag([10.0, 10.0, 1.0, 1.0]), np.eye(1))
    E_up = plant.energy(up)

    hist = {name: [] for name in ("x", "x_filtered", "u", "u_friction", "u_gravity")}

    def pfl(t, x):   # energy shaping through a collocated PFL (the swing-up)
        M, C = plant.mass_matrix(x), plant.coriolis_matrix(x)
        G, F = plant.gravity_vector(x), plant.coulomb_vector(x)
        h = C.dot(np.copy(x[2:])) - G + F
        a2 = 2.0 * (E_up - plant.energy(x)) * x[2] - 50.0 * x[1] - 5.0 * x[3]
        a1 = -(M[0, 1] * a2 + h[0]) / M[0, 0]
        return np.array([0.0, M[1, 0] * a1 + M[1, 1] * a2 + h[1]])

    def lqr(t, x):   # the balance about the upright state
        e = np.copy(x) - up
        e[0] = (e[0] + np.pi) % (2 * np.pi) - np.pi
        return np.array([0.0, -K.dot(e)[0]])

    def control(t, x):
        """A controller call as the peer's controllers make it: the state
        recorded and filtered (identity), both laws' switching condition
        checked, the chosen law, friction compensation through the friction
        regressor (off: zero terms) and gravity compensation (off)."""
        hist["x"].append(x)
        y = np.copy(x)
        hist["x_filtered"].append(y)
        e = np.copy(y) - up
        e[0] = (e[0] + np.pi) % (2 * np.pi) - np.pi
        near = float(e.dot(np.diag([1.0, 1.0, 0.1, 0.1]).dot(e))) < 0.1
        u = np.asarray(lqr(t, y) if near else pfl(t, y))
        regressor = np.array([[np.arctan(100 * y[2]), y[2], 0.0, 0.0],
                              [0.0, 0.0, np.arctan(100 * y[3]), y[3]]])
        u_fric = np.dot(regressor, np.zeros(4))
        hist["u_friction"].append(u_fric)
        u = u + u_fric
        u_grav = np.asarray([0.0, 0.0])
        hist["u_gravity"].append(u_grav)
        u = u + u_grav
        hist["u"].append(u)
        return u

    def run(T):
        x, t = np.array([0.3, 0.0, 0.0, 0.0]), 0.0
        ts, xs, us = [], [], []
        while t < T:
            tau = np.clip(control(t, x), -limit, limit)
            k1 = plant.rhs(t, x, tau)
            k2 = plant.rhs(t + 0.5 * dt, x + 0.5 * dt * k1, tau)
            k3 = plant.rhs(t + 0.5 * dt, x + 0.5 * dt * k2, tau)
            k4 = plant.rhs(t + dt, x + dt * k3, tau)
            x = x + dt * (k1 + 2 * (k2 + k3) + k4) / 6.0
            t += dt
            ts.append(t)
            xs.append(x.copy())
            us.append(tau)
        return t

    run(0.2)   # warm up
    t0 = time.perf_counter()
    simulated = run(duration)
    return simulated / (time.perf_counter() - t0)


def free_swing_rate(duration: float = 20.0) -> float:
    """Simulated s per wall s of plant + friction swinging freely (the
    swing's integrator accuracy, logging at 1 ms, energies computed)."""
    from bplir_drake.analysis.model.freeswing import simulate_free_swing
    from bplir_drake.analysis.swing.run import SWING_ACCURACY
    from bplir_drake.params import preset

    p = preset()
    simulate_free_swing(p, (1.0, 0.5), 1.0)  # warm up
    t0 = time.perf_counter()
    simulate_free_swing(p, (1.0, 0.5), duration, accuracy=SWING_ACCURACY)
    return duration / (time.perf_counter() - t0)


def python_tick_floor(systems: int = 7, duration: float = 20.0, period: float = 0.01):
    """(rate without, rate with) ``systems`` Python LeafSystems that do no
    work but tick at the controller's rate (each reads the plant state at
    its periodic discrete update and stores one number) on the free swing
    of :func:`free_swing_rate`, in one run: the cost of the closed loop's
    100 Hz Python chain (IMU sampler, EKF, delay identifier, delay
    predictor, plan tracker, interlock, driver logic) before any of them
    computes anything."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder, LeafSystem
    from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

    from bplir_drake.analysis.swing.run import SWING_ACCURACY
    from bplir_drake.diagrams.parts import add_plant_with_friction
    from bplir_drake.params import preset

    class EmptyTick(LeafSystem):
        def __init__(self):
            super().__init__()
            self._x = self.DeclareVectorInputPort("state", 4)
            self.DeclareDiscreteState(1)
            self.DeclarePeriodicDiscreteUpdateEvent(period, 0.0, self._update)

        def _update(self, context, discrete_state):
            discrete_state.set_value([self._x.Eval(context)[0]])

    def rate(k: int) -> float:
        p = preset()
        b = DiagramBuilder()
        plant, fr = add_plant_with_friction(b, p.simulated_plant, p.simulated_friction)
        src = b.AddSystem(ConstantVectorSource([0.0]))
        b.Connect(src.get_output_port(0), plant.get_actuation_input_port())
        for port in (plant.get_state_output_port(), fr.get_output_port(0)):
            LogVectorOutput(port, b, 0.001)
        for _ in range(k):
            b.Connect(plant.get_state_output_port(), b.AddSystem(EmptyTick()).get_input_port(0))
        sim = Simulator(b.Build())
        ctx = sim.get_mutable_context()
        plant.SetPositions(plant.GetMyMutableContextFromRoot(ctx), [1.0, 0.5])
        sim.get_mutable_integrator().set_target_accuracy(SWING_ACCURACY)
        sim.get_mutable_integrator().set_maximum_step_size(0.01)
        sim.Initialize()
        t0 = time.perf_counter()
        sim.AdvanceTo(duration)
        return duration / (time.perf_counter() - t0)

    rate(0)   # warm up
    return rate(0), rate(systems)


def python_systems() -> int:
    """How many of the default swing diagram's systems are Python
    ``LeafSystem`` s (the 100 Hz chain: IMU sampler, EKF, delay
    identifier, predictor, plan tracker, interlock, driver logic)."""
    from bplir_drake.analysis.swing.run import swing_diagram
    from bplir_drake.params import preset

    def leaves(d):
        for s in d.GetSystems():
            yield from (leaves(s) if hasattr(s, "GetSystems") else (s,))

    built = swing_diagram(preset().resolved(), seed=0)
    return sum(type(s).__module__.startswith("bplir_drake") for s in leaves(built.diagram))


def cpp_ceiling(seeds: int = 5, accuracies=(1e-4, 1e-3)):
    """{accuracy: simulated s per wall s} of the closed loop's C++ part
    alone: the same simulated robot (plant, friction, motor and driver), its
    four Drake IMU sensors sampled at the tick by C++ zero-order holds, the
    plant state sampled likewise (what the interlock and a true-state
    controller read), the same continuous loggers, and each swing's logged
    commands replayed through the compute latency -- everything but the
    Python chain (IMU error model, EKF, predictor, plan tracker, interlock,
    delay identification).  The highest rate the closed loop could reach
    with a chain that costs nothing, at each integrator accuracy."""
    from pydrake.systems.framework import DiagramBuilder
    from pydrake.systems.primitives import LogVectorOutput, TrajectorySource, ZeroOrderHold
    from pydrake.trajectories import PiecewisePolynomial

    from bplir_drake.analysis.swing.run import SWING_INTEGRATOR, run_swing
    from bplir_drake.diagrams.parts import Built, add_imu_sensors
    from bplir_drake.diagrams.swing import add_robot
    from bplir_drake.params import preset
    from bplir_drake.simulate import make_simulator

    p = preset().resolved()
    T, latency = p.controller.period, p.controller.compute_latency
    swings = []
    for seed in range(seeds):
        r = run_swing(p, seed=seed)
        cmd = r.logs["command"]
        swings.append((seed, np.append(cmd.t, cmd.t[-1] + 1e3), cmd.data[:, 0],
                       r.logs["state"].t[-1], r.summary["start_configuration_rad"]))
    rates = {}
    for acc in accuracies:
        sim_s = wall = 0.0
        for seed, t, u, duration, q0 in swings:
            b = DiagramBuilder()
            robot = add_robot(b, p, seed)
            plant = robot.plant
            replay = b.AddSystem(TrajectorySource(PiecewisePolynomial.ZeroOrderHold(
                t, np.append(u, u[-1]).reshape(1, -1))))
            hold = b.AddSystem(ZeroOrderHold(T, 1, latency))
            b.Connect(replay.get_output_port(0), hold.get_input_port(0))
            b.Connect(hold.get_output_port(0), robot.motor.GetInputPort("torque_command"))
            for sensors in add_imu_sensors(b, plant, p):
                for port in sensors:
                    sample = b.AddSystem(ZeroOrderHold(T, 3))
                    b.Connect(port, sample.get_input_port(0))
                    LogVectorOutput(sample.get_output_port(0), b, T)
            state = b.AddSystem(ZeroOrderHold(T, 4))
            b.Connect(plant.get_state_output_port(), state.get_input_port(0))
            LogVectorOutput(state.get_output_port(0), b, T)
            LogVectorOutput(plant.get_state_output_port(), b, 0.005)
            LogVectorOutput(robot.friction.get_output_port(0), b, 0.005)
            for name in ("torque", "power", "current", "tripped"):
                LogVectorOutput(robot.motor.GetOutputPort(name), b, 0.005)

            sim = make_simulator(Built(b.Build(), plant), q0, accuracy=acc,
                                 integrator=SWING_INTEGRATOR)
            t0 = time.perf_counter()
            sim.AdvanceTo(duration)
            wall += time.perf_counter() - t0
            sim_s += duration
        rates[acc] = sim_s / wall
    return rates


def closed_loop(seeds: int):
    """(simulated s, wall s, outcomes) of ``run_swing`` over seeds 0..seeds-1
    (warm: the first swing of the process is run once before timing)."""
    from bplir_drake.analysis.swing.run import run_swing
    from bplir_drake.params import preset

    p = preset()
    run_swing(p, seed=0)
    sim = wall = 0.0
    outcomes = collections.Counter()
    for seed in range(seeds):
        t0 = time.perf_counter()
        r = run_swing(p, seed=seed)
        wall += time.perf_counter() - t0
        sim += r.logs["state"].t[-1]
        outcomes[r.summary["outcome"]] += 1
    return sim, wall, outcomes


def reuse(seeds: int):
    """(wall s with a fresh diagram per swing, wall s with one SwingRunner
    reusing its diagram) over the same seeds, in one run: what setting a
    Monte Carlo sample in the context saves."""
    from bplir_drake.analysis.swing.run import SwingRunner, run_swing
    from bplir_drake.params import preset

    p = preset()
    runner = SwingRunner()
    runner.run(p, seed=0)
    t0 = time.perf_counter()
    for seed in range(seeds):
        run_swing(p, seed=seed)
    fresh = time.perf_counter() - t0
    t0 = time.perf_counter()
    for seed in range(seeds):
        runner.run(p, seed=seed)
    return fresh, time.perf_counter() - t0


def breakdown():
    """Wall time of the Python callbacks of one swing (exclusive of nested
    calls is not separated: the plan tracker's tick pulls the predictor's,
    which pulls the estimator's; on the path generator the controller's
    tick pulls the path's)."""
    from bplir_drake.analysis.swing.run import run_swing
    from bplir_drake.params import preset
    from bplir_drake.systems import ekf, gripper, imu, motor, path, plan_tracker, predictor
    from bplir_drake.systems.controller import DiscreteCpflController

    spent = collections.defaultdict(float)

    def wrap(cls, name, label):
        f = getattr(cls, name)

        @functools.wraps(f)
        def timed(*a, **k):
            t0 = time.perf_counter()
            try:
                return f(*a, **k)
            finally:
                spent[label] += time.perf_counter() - t0
        setattr(cls, name, timed)

    p = preset()
    run_swing(p, seed=0)
    wrap(path, "step_blend_end", "path: arrival predictor (adaptation)")
    wrap(ekf.KinematicEkf, "_posterior", "EKF update")
    wrap(imu.ImuSampler, "_sample", "IMU sampler")
    wrap(gripper.GripperInterlock, "_update", "interlock")
    wrap(DiscreteCpflController, "_tick_law", "controller tick (incl. path, EKF)")
    wrap(motor.DriverLogic, "_update", "driver i2t")
    # the default: plan tracking (its tick pulls the predictor's, which
    # pulls the EKF's), the delay predictor, the apex landing
    wrap(plan_tracker.PlanTracker, "_tick_law", "plan tracker tick (incl. predictor, EKF)")
    wrap(predictor.DelayPredictor, "_predict", "delay predictor (incl. EKF)")
    wrap(plan_tracker.Landing, "torque", "apex landing law")
    t0 = time.perf_counter()
    run_swing(p, seed=0)
    total = time.perf_counter() - t0
    return total, dict(spent)


def main():
    import platform
    import os

    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 10
    free = free_swing_rate()
    sim, wall, outcomes = closed_loop(seeds)
    loop = sim / wall
    peer = reference_loop_rate()
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}")
    print(f"the peer's kind of loop (plain NumPy RK4 at 2 ms, PFL + LQR, no estimator; "
          f"reference_loop_rate): {peer:.1f} simulated s per wall s")
    print(f"closed loop / that reference: {loop / peer:.2f} (goal >= 1.25)")
    print(f"plant-only free swing (20 s): {free:.1f} simulated s per wall s")
    print(f"closed-loop swing, EKF in the loop, seeds 0-{seeds - 1}: {sim:.2f} s simulated in "
          f"{wall:.2f} s wall = {loop:.1f} simulated s per wall s "
          f"({wall / seeds * 1e3:.0f} ms per swing; {dict(outcomes)})")
    print(f"ratio closed loop / free swing: {loop / free:.3f}; goal >= 20 simulated s per wall s: "
          f"{'met' if loop >= 20 else 'not met'}")
    ceiling = cpp_ceiling()
    from bplir_drake.analysis.swing.run import SWING_ACCURACY

    print("the closed loop's C++ part alone (plant, friction, motor, the four Drake IMU sensors "
          "and the state sampled at the ticks, the loggers; the commands replayed; seeds 0-4): "
          + ", ".join(f"{rate:.1f} simulated s per wall s at accuracy {acc:g}"
                      + (" (the swing's)" if acc == SWING_ACCURACY else "")
                      for acc, rate in ceiling.items())
          + f"; the whole closed loop reaches {loop / ceiling[SWING_ACCURACY]:.2f} of its ceiling")
    n = python_systems()
    bare, ticked = python_tick_floor(n)
    print(f"free swing {bare:.1f} simulated s per wall s; with {n} empty Python systems ticking "
          f"at 100 Hz (as many as the swing has) {ticked:.1f} (ratio {ticked / bare:.3f}): "
          "what their events cost before they compute anything")
    tick_cost = 1.0 / ticked - 1.0 / bare   # wall s per simulated s
    for acc, rate in ceiling.items():
        print(f"  the closed loop's bound at accuracy {acc:g} with a Python chain that computes "
              f"nothing: {1.0 / (1.0 / rate + tick_cost):.1f} simulated s per wall s "
              "(its C++ part plus those events)")
    fresh, reused = reuse(seeds)
    print(f"{seeds} swings, a diagram built per swing {fresh:.2f} s, one diagram reused "
          f"(samples set in the context) {reused:.2f} s: ratio {reused / fresh:.3f}")
    total, spent = breakdown()
    print(f"one swing {total * 1e3:.0f} ms; Python callbacks (inclusive):")
    for k, v in sorted(spent.items(), key=lambda kv: -kv[1]):
        print(f"  {k:40s} {v * 1e3:6.1f} ms ({v / total:4.0%})")


if __name__ == "__main__":
    main()
