"""How a plan's solve ended, in words: the solver's result, and the
one-line reason when there is no plan."""
from __future__ import annotations

import math


#: Drake's solution results in words (a plan's ``status``)
SOLVER_STATUS = {"kSolutionFound": "solved", "kInfeasibleConstraints": "infeasible",
                 "kIterationLimit": "iteration limit", "kSolverSpecificError": "solver error",
                 "kInvalidInput": "invalid input", "kUnbounded": "unbounded"}


def no_plan_message(plan: SwingPlan) -> str:
    """Why there is no plan, in one line: the solver proved the limits
    cannot be met, or it merely stopped without meeting them (which proves
    nothing: a plan may still exist)."""
    volts = (f", {plan.voltage_share:g} of {plan.voltage_limit:g} V at the knots"
             if math.isfinite(plan.voltage_limit) else "")
    limits = f"{plan.torque_limit:g} N m and {plan.power_limit:g} W{volts}"
    if plan.status == "infeasible":
        return (f"no feasible plan for a {plan.incline_deg:g} deg line within {limits}: the "
                "solver found the limits cannot be met")
    return (f"no plan found for a {plan.incline_deg:g} deg line within {limits}: the solver "
            f"stopped without converging ({plan.status or 'unknown'}), which does not show that "
            "none exists; try another grip spacing, end depth or limit")
