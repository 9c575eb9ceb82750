"""``bplir plan``: a swing planned by trajectory optimisation."""
from __future__ import annotations

from ..io import atomic_path
from .common import InputError, _emit, _load_params, _out_dir, _progress, _save, _write_json
from .options import command, option, shared


# ------------------------------------------------------------------ plan
def cmd_plan(args) -> int:
    """``bplir plan``: plan a swing by trajectory optimisation."""
    import numpy as np

    from ..planning.solve import energy_balance, hanging_plan, plan_swing, planned_i2t, pump_plan
    from ..planning.figure import plot_plan
    from ..params import Manoeuvre, derive
    from ..systems.motor import interlock_budget

    if args.pump and (args.knots is not None or args.power is not None):
        raise InputError("--pump plans on its own knots within the motor's power rating; "
                         "allowed without --knots and --power")
    params = derive(_load_params(args), Manoeuvre(gripper=args.gripper, incline_deg=args.incline,
                                                  reach="pump" if args.pump else None))
    out = _out_dir(args.out)
    # plan_swing validates the scenario, the power limit and the knots
    given = {} if args.knots is None else {"knots": args.knots}   # else each planner's own
    if params.scenario.manoeuvre_of() == "pump":
        plan = pump_plan(params, progress=_progress(args), strict=False)
    elif params.scenario.start == "hanging":   # the pump a swing from hanging tracks
        plan = hanging_plan(params, power_limit=args.power, progress=_progress(args),
                            strict=False, **given)
    else:
        plan = plan_swing(params, power_limit=args.power, progress=_progress(args), **given)
    figure = None if args.no_plots else _save(args, plot_plan(plan, params), out / "plan.png")
    heat = planned_i2t(plan, params.motor) / interlock_budget(params.motor)
    balance = energy_balance(plan, params.plant)
    summary = plan.summary() | {"i2t_share": heat, "manoeuvre": params.scenario.manoeuvre_of(),
                                "energy_residual_share": balance["residual_share"],
                                "figure": None if figure is None else str(figure)}
    _write_json(out / "plan.json", summary)
    with atomic_path(out / "plan.csv") as tmp:
        np.savetxt(tmp, np.c_[plan.times, plan.states, plan.torque],
                   delimiter=",", header="t,q1,q2,q1d,q2d,tau", comments="")
    verdict = ((("feasible and optimal" if plan.solved else "feasible, not proven optimal")
                + f" (solver {plan.solver}" + (f": {plan.status})" if plan.status else ")"))
               if plan.feasible else "NOT feasible: the limits cannot be met"
               if plan.status == "infeasible" else
               "NOT feasible: its plan does not keep the robot's energy"
               if plan.status == "energy not kept" else
               f"NOT feasible: the solver stopped without converging ({plan.status}); a plan "
               "may still exist")
    _emit(summary, args.json, [
        f"planned swing on a {plan.incline_deg:g} deg line: {verdict}",
        f"  duration {plan.duration:.3f} s, peak torque {plan.peak_torque:.1f} N m, "
        f"peak power {plan.peak_power:.0f} W (limit {plan.power_limit:g} W)",
        f"  motor work {plan.energy_in:.1f} J, friction loss {plan.dissipated:.1f} J, "
        f"the robot's energy {balance['change_J']:+.1f} J ({100 * balance['residual_share']:.1f} "
        f"% unaccounted), link 1 reverses {plan.link1_reversals}x",
        f"  the planned torque alone uses {100 * heat:.0f} % of the driver's i^2 t budget "
        "(from a reset driver)",
        f"  wrote {out}/{'' if figure is None else 'plan.png, '}plan.csv, plan.json"])
    return 0 if plan.feasible else 1


def add_parser(sub) -> None:
    """Declare ``bplir plan`` and its options."""
    p = command(sub, "plan", cmd_plan,
                "plan a swing by trajectory optimisation (torque and power limits)", "out/plan")
    shared(p, "incline")
    option(p, "--power", float, None, "motor power limit in W (default: rating)")
    option(p, "--knots", int, None, "collocation knots (default 41; 61 from hanging, "
           "scenario.start = hanging, where the guesses of a swing from hanging are tried)")
    option(p, "--no-plots", bool, help="skip the figure (plan.png)")
    option(p, "--gripper", int, 1, "the gripper the robot holds with (2: the robot seen from "
           "its other gripper)", choices=(1, 2))
    option(p, "--pump", bool, help="a pumping manoeuvre from the line (scenario.manoeuvre = "
           "pump: link 1 swings back and forth as often as its plan needs)")
