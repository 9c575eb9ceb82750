"""Benchmark: simulated seconds per wall second of the default closed-loop
swing (EKF in the loop) and of the plant-only free swing, in one run, and
where the time of the closed loop goes.

Run: python benchmarks/bench_swing.py [SEEDS]   (default 10; prints figures,
not a test).  Goals (issue 69): the closed loop (its diagram built, as a
study runs it: :func:`closed_loop`) >= 1.25 times the rate of a same-run
reference loop of the DFKI simulator's kind (``peer_loop.reference_loop_rate``,
its set-up not timed either), and the 100 Hz chain's cost <= 100 us a tick
in its timed breakdown (:func:`breakdown`, the median of three: its
Python callbacks, inclusive).  It also prints the ceiling of the rate: the closed loop's C++
part alone, with every Python system of the 100 Hz chain taken out and the
commands replayed (:func:`cpp_ceiling`).
"""
import collections
import functools
import sys
import time

import numpy as np


def free_swing_rate(duration: float = 20.0) -> float:
    """Simulated s per wall s of plant + friction swinging freely (the
    swing's integrator accuracy, logging at 1 ms, energies computed)."""
    from bplir_drake.analysis.model.freeswing import simulate_free_swing
    from bplir_drake.analysis.swing.swing_runner import SWING_ACCURACY
    from bplir_drake.params import preset

    p = preset()
    simulate_free_swing(p, (1.0, 0.5), 1.0)  # warm up
    t0 = time.perf_counter()
    simulate_free_swing(p, (1.0, 0.5), duration, accuracy=SWING_ACCURACY)
    return duration / (time.perf_counter() - t0)


def python_tick_floor(systems: int = 2, duration: float = 20.0, period: float = 0.01):
    """(rate without, rate with) ``systems`` Python LeafSystems that do no
    work but tick at the controller's rate (each reads the plant state at
    its periodic discrete update and stores one number) on the free swing
    of :func:`free_swing_rate`, in one run: the cost of the closed loop's
    100 Hz Python chain (the onboard computer and the interlock) before
    either computes anything."""
    from pydrake.systems.analysis import Simulator
    from pydrake.systems.framework import DiagramBuilder, LeafSystem
    from pydrake.systems.primitives import ConstantVectorSource, LogVectorOutput

    from bplir_drake.analysis.swing.swing_runner import SWING_ACCURACY
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
    ``LeafSystem`` s (the 100 Hz chain: the onboard computer -- IMU
    sampler, EKF, delay identifier, predictor and plan tracker as one
    system -- and the interlock)."""
    from bplir_drake.analysis.swing.swing_runner import swing_diagram
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

    from bplir_drake.analysis.swing.swing_runner import SWING_INTEGRATOR, run_swing
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


def closed_loop(seeds: int, reused: bool = True):
    """(simulated s, wall s, outcomes) of the default swings of seeds
    0..seeds-1.  ``reused``: as a study runs them, through one
    ``SwingRunner`` whose diagram is built once (each swing's sample set in
    a fresh context, the simulator made and initialised, the swing
    simulated, its logs and summary read) -- the real-time factor of the
    simulation, as the reference loop's excludes its set-up; else
    ``run_swing``, a diagram built for every swing.  Warm: the first swing
    is run once before timing."""
    from bplir_drake.analysis.swing.swing_runner import SwingRunner, run_swing
    from bplir_drake.params import preset

    p = preset()
    runner = SwingRunner()
    swing = runner.run if reused else run_swing
    swing(p, seed=0)
    sim = wall = 0.0
    outcomes = collections.Counter()
    for seed in range(seeds):
        t0 = time.perf_counter()
        r = swing(p, seed=seed)
        wall += time.perf_counter() - t0
        sim += r.logs["state"].t[-1]
        outcomes[r.summary["outcome"]] += 1
    return sim, wall, outcomes


def chain_cost(seeds: int, ceiling: float, period: float = 0.01) -> float:
    """The 100 Hz chain's own cost (us a tick): the wall time of the closed
    loop's integration (``run_until_outcome``: the chain's events and
    outputs included, the diagram's set-up and the summary not) over seeds
    0..seeds-1, less the C++ part's at the same accuracy (``ceiling``,
    simulated s per wall s, :func:`cpp_ceiling`), per tick."""
    from bplir_drake.analysis.swing import swing_runner as run_module
    from bplir_drake.params import preset

    inner, spent = run_module.run_until_outcome, [0.0, 0.0]

    def timed(sim, *a, **k):
        t0, start = time.perf_counter(), sim.get_context().get_time()
        try:
            return inner(sim, *a, **k)
        finally:
            spent[0] += time.perf_counter() - t0
            spent[1] += sim.get_context().get_time() - start

    runner = run_module.SwingRunner()
    runner.run(preset(), seed=0)
    run_module.run_until_outcome = timed
    try:
        for seed in range(seeds):
            runner.run(preset(), seed=seed)
    finally:
        run_module.run_until_outcome = inner
    wall, simulated = spent
    return (wall - simulated / ceiling) / (simulated / period) * 1e6


def breakdown(seeds: int, parts: bool = False):
    """The timed breakdown of the 100 Hz chain: the wall time of its
    Python callbacks over the default swings of seeds 0..seeds-1 run as
    :func:`closed_loop` runs them, inclusive, per tick: the onboard
    computer's tick (with the C++ sensors it reads) and the interlock (the
    motor and driver are C++).  ``parts``: the onboard tick's parts timed
    within it too (the compiled tick: the IMU sample, the EKF step, the
    prediction and the plan tracker's time-indexed tick; the tracker's
    ticks in Python, where its terminal law runs), whose timers then add to
    the tick's own time.  Returns (ticks, wall s of the swings,
    {label: wall s})."""
    from bplir_drake.analysis.swing.swing_runner import SwingRunner
    from bplir_drake.params import preset
    from bplir_drake.systems import gripper, onboard, onboard_kernel, plan_tracker

    spent, restore = collections.defaultdict(float), []

    def wrap(owner, name, label):
        f = owner.__dict__[name]
        call = f.__func__ if isinstance(f, staticmethod) else f

        @functools.wraps(call)
        def timed(*a, **k):
            t0 = time.perf_counter()
            try:
                return call(*a, **k)
            finally:
                spent[label] += time.perf_counter() - t0
        setattr(owner, name, staticmethod(timed) if isinstance(f, staticmethod) else timed)
        restore.append((owner, name, f))

    wrap(onboard.OnboardComputer, "_tick", TICK)
    wrap(gripper.GripperInterlock, "_update", "interlock")
    if parts:
        wrap(onboard_kernel, "tick",
             "  IMU sample, EKF step, prediction, tracker (compiled)")
        wrap(plan_tracker.PlanTracker, "tick", "  plan tracker's terminal-law ticks (Python)")
    try:
        p = preset()
        runner = SwingRunner()   # built after the wrapping: its events hold the wrapped methods
        runner.run(p, seed=0)
        spent.clear()
        ticks, t0 = 0, time.perf_counter()
        for seed in range(seeds):
            ticks += len(runner.run(p, seed=seed).logs["command"].t)
        return ticks, time.perf_counter() - t0, dict(spent)
    finally:
        for owner, name, f in reversed(restore):
            setattr(owner, name, f)


#: the onboard computer's tick in :func:`breakdown`
TICK = "onboard tick (sample, EKF, predictor, tracker)"


def main():
    import platform
    import os

    seeds = int(sys.argv[1]) if len(sys.argv) > 1 else 10
    free = free_swing_rate()
    from peer_loop import reference_loop_rate

    # the two measured in turn, three times: a machine whose speed drifts
    # slows both alike; the median of the three ratios is the figure
    pairs = []
    for _ in range(3):
        sim, wall, outcomes = closed_loop(seeds)
        pairs.append((sim / wall, reference_loop_rate()))
    loop, peer = sorted(pairs, key=lambda lp: lp[0] / lp[1])[1]
    wall = sim / loop
    fresh_sim, fresh_wall, _ = closed_loop(seeds, reused=False)
    print(f"machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores, "
          f"Python {platform.python_version()}")
    print(f"the peer's kind of loop (plain NumPy RK4 at 2 ms, PFL + LQR, no estimator; "
          f"reference_loop_rate, its set-up not timed): {peer:.1f} simulated s per wall s")
    print(f"closed loop / that reference: {loop / peer:.2f} (goal >= 1.25; the median of "
          "three measured in turn: " + ", ".join(f"{a / b:.2f}" for a, b in pairs) + ")")
    print(f"plant-only free swing (20 s): {free:.1f} simulated s per wall s")
    print(f"closed-loop swing, EKF in the loop, seeds 0-{seeds - 1}, its diagram built (one "
          f"SwingRunner, as a study): {sim:.2f} s simulated in {wall:.2f} s wall = {loop:.1f} "
          f"simulated s per wall s ({wall / seeds * 1e3:.0f} ms per swing; {dict(outcomes)})")
    print(f"  a diagram built for every swing (run_swing): {fresh_sim / fresh_wall:.1f} "
          f"simulated s per wall s ({fresh_wall / seeds * 1e3:.0f} ms per swing), "
          f"{fresh_sim / fresh_wall / peer:.2f} of the reference")
    print(f"ratio closed loop / free swing: {loop / free:.3f}")
    ceiling = cpp_ceiling()
    from bplir_drake.analysis.swing.swing_runner import SWING_ACCURACY

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
    runs = sorted((breakdown(seeds) for _ in range(3)),
                  key=lambda r: (r[2][TICK] + r[2]["interlock"]) / r[0])
    costs = [(r[2][TICK] + r[2]["interlock"]) / r[0] * 1e6 for r in runs]
    ticks, total, spent = runs[1]   # the median of three
    print(f"the 100 Hz chain's timed breakdown, seeds 0-{seeds - 1} ({ticks} ticks, "
          f"{total / seeds * 1e3:.0f} ms a swing): its Python callbacks "
          f"{costs[1]:.0f} us a tick (goal <= 100; the median of three: "
          f"{', '.join(f'{c:.0f}' for c in costs)}), inclusive:")
    for k, v in spent.items():
        print(f"  {k:48s} {v / ticks * 1e6:6.1f} us a tick ({v / total:4.0%} of the time)")
    ticks, total, spent = breakdown(seeds, parts=True)
    print("  the onboard tick's parts, timed within it in a run of their own (their timers "
          f"add to the tick: {spent[TICK] / ticks * 1e6:.1f} us a tick in that run):")
    for k, v in spent.items():
        if k.startswith("  "):
            print(f"  {k:48s} {v / ticks * 1e6:6.1f} us a tick")
    per_tick = chain_cost(seeds, ceiling[SWING_ACCURACY])
    print(f"  the closed loop's integration less its C++ part measured apart (an estimate "
          f"of the same, with the machine's drift between the two): {per_tick:.0f} us a tick")


if __name__ == "__main__":
    main()
