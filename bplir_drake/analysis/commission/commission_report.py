"""The commissioning report: its figure (from the result's data) and its
markdown page."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ...io import write_text_atomic
from ...plotting import figure_axes, finish, save_figure
from .similarity import Scales, shipped_references
from .verdict import READY_RATE

FIGURE = "commission"


def plot_commission(result, axes=None):
    """Four panels: each grid point's plan duration in the robot's own
    units (over sqrt(L/g)) against the grip spacing over the reach, a line
    per holding gripper, incline and manoeuvre, beside the default robot's
    shipped single-swing plans (grey, dotted); the share of the elbow's
    torque limit (filled) and of the driver's voltage (open) each plan
    uses, so the one that binds shows; each study's capture rate with its
    Wilson 95 % interval (the bar dotted); and how hard it lands: each
    study's capture speed p95 against the gripper's limit."""
    fig, ax = figure_axes(axes, 1, 4, figsize=(15, 3.8))
    own = Scales.of(result.params.plant)
    refs = [r for r in shipped_references() if r.start == "line"][:1]
    line = [p for p in result.points if p.start == "line"]
    torque, volts = result.params.controller.torque_limit, result.params.motor.max_voltage
    for g, a, kind in sorted({(p.holding, p.incline_deg, p.manoeuvre) for p in line}):
        rows = sorted((p for p in line if p.incline_deg == a and p.holding == g
                       and p.manoeuvre == kind), key=lambda p: p.spacing_m)
        d = [p.spacing_m / own.length for p in rows]
        style = ("o" if g == 1 else "s") + ("-" if kind == "swing" else ":")
        label = f"gripper {g}, {a:+g} deg" + ("" if kind == "swing" else f", {kind}")
        ax[0].plot(d, [p.duration_s / own.time for p in rows], style, label=label)
        shown = ax[1].plot(d, [p.peak_torque_Nm / torque for p in rows], style)[0]
        ax[1].plot(d, [p.peak_voltage_V / volts for p in rows], style, mfc="none",
                   color=shown.get_color())
    for a in sorted({p.incline_deg for p in result.points}):
        for ref in refs:
            lib, sc = ref.library, Scales.of(ref.plant)
            i = int(np.argmin(np.abs(lib.inclines - a)))
            ax[0].plot(lib.spacings / sc.length, lib.durations[i] / sc.time, ":", color="0.6",
                       lw=1, label=f"default robot, {lib.inclines[i]:+g} deg")
    ax[0].set(xlabel="grip spacing / reach  D / L", ylabel="plan duration / sqrt(L/g)",
              title="plans, in the robot's units")
    ax[0].legend(fontsize=6, loc="center right")
    ax[1].axhline(1.0, ls="-.", color="0.3", lw=1)
    ax[1].set(xlabel="grip spacing / reach  D / L", ylabel="share of the limit",
              title=f"filled: torque of {torque:g} N m\nopen: voltage of {volts:.1f} V",
              ylim=(0, 1.1))
    studies = sorted(result.studies, key=lambda s: (s.incline_deg, s.holding))
    names = [f"gripper {st.holding}\n{st.manoeuvre}" + ("" if st.chosen else "\n(not chosen)")
             + f"\n{st.incline_deg:+g} deg" for st in studies]
    for k, st in enumerate(studies):
        y, (lo, hi) = 100 * st.rate, st.wilson95
        mark, colour = ("o" if st.holding == 1 else "s"), f"C{st.holding - 1}"
        ax[2].errorbar([k], [y], yerr=[[y - 100 * lo], [100 * hi - y]], fmt=mark, capsize=4,
                       color=colour)
        ax[2].annotate(f"{st.captured}/{st.samples}", (k, y), textcoords="offset points",
                       xytext=(0, 6), ha="center", fontsize=8)
        ax[3].plot([k], [st.capture_speed_p95_mps], mark, color=colour)
    for a in ax[2:]:
        a.set_xticks(range(len(studies)), names, fontsize=7)
        a.set_xlim(-0.6, max(len(studies), 1) - 0.4)
    ax[2].axhline(100 * READY_RATE, ls=":", color="0.4", lw=1)
    ax[2].set(ylabel="captured (%)", ylim=(0, 108), title="verification studies")
    limit = result.params.gripper.capture_speed
    ax[3].axhline(limit, ls="-.", color="0.3", lw=1)
    ax[3].set(ylabel="capture speed p95 [m/s]", ylim=(0, 1.15 * limit),
              title=f"landing (the gripper takes {limit:g} m/s)")
    caption = (f"{result.name}: reach L {own.length:.3f} m, mass m "
               f"{result.params.plant.m1 + result.params.plant.m2:.3f} kg, sqrt(L/g) "
               f"{own.time:.3f} s, m g L {own.torque:.2f} N m; studies' root seed "
               f"{result.seed}; Wilson 95 % intervals")
    return finish(fig, f"Commissioning: {result.name}", caption)


def _by(row: dict) -> str:
    """A row's manoeuvre from the line when it is a pump, and whether it was
    the one chosen (a single swing says nothing)."""
    if row.manoeuvre == "swing" and row.chosen:
        return ""
    return f", {row.manoeuvre}" + ("" if row.chosen else
                                                   " (not chosen)")


def _num(x, fmt=".2f") -> str:
    return "-" if x is None or (isinstance(x, float) and math.isnan(x)) else format(x, fmt)


def report_markdown(result, fmt: str = "png") -> str:
    """The report as markdown (its figure a ``fmt`` file)."""
    s = result.summary()
    lines = [f"# Commissioning report: {result.name}", "",
             f"**Verdict: {s['verdict']}.** "
             f"{s['plans']['solved']} of {s['plans']['points']} plans solved "
             f"({s['plans']['from_similarity']} from similar robots' plans), "
             f"{s['wall_s']:.0f} s.", ""]
    if s["manoeuvre"] != result.params.scenario.manoeuvre:
        lines += [f"A traversal does what this commission chose (and uses its plans) with "
                  f"`manoeuvre = \"{s['manoeuvre']}\"` in the robot's `[scenario]` (holding "
                  "with gripper 1, with gripper 2).", ""]
    if s["limits"]:
        lines += ["## Limits", ""] + [f"- {x}" for x in s["limits"]] + [""]
    if s["unshown"]:
        lines += ["## Not shown", "", f"Ready means the lower end of each study's Wilson 95 % "
                  f"interval at or above {100 * READY_RATE:.0f} %.", ""]
        lines += [f"- {x}" for x in s["unshown"]] + [""]
    lines += ["## Verification studies", "",
              f"Root seed {result.seed}; uncertainty scaled to the robot.", "",
              "| holding | incline (deg) | captured | Wilson 95 % | capture speed p50 / p95 (m/s) "
              "| peak voltage (V) | peak torque (N m) |",
              "| --- | --- | --- | --- | --- | --- | --- |"]
    for st in result.studies:
        lo, hi = st.wilson95
        lines.append(f"| gripper {st.holding}{_by(st)} | {st.incline_deg:+g} | "
                     f"{st.captured}/{st.samples} | "
                     f"{100 * lo:.1f}-{100 * hi:.1f} % | {_num(st.capture_speed_p50_mps)} / "
                     f"{_num(st.capture_speed_p95_mps)} | {_num(st.peak_voltage_V, '.1f')} | "
                     f"{_num(st.peak_torque_Nm)} |")
    lines += _landing_lines(result.studies)
    if s["unbalanced"]:
        lines += ["", "## Plans that do not keep the robot's energy", "",
                  "The elbow's work less the friction's should be the robot's change of energy; "
                  "these plans gain energy between their collocation knots, which their tracking "
                  "has to find:", ""] + [f"- {x}" for x in s["unbalanced"]]
    if s["binding"]:
        lines += ["", "## What binds the plans", ""]
        lines += [f"- gripper {g}: {x}" for g, x in s["binding"].items() if x]
    m = s["margins"]
    if m:
        lines += ["", "## Electric margins of the plans", "",
                  f"- peak voltage {m['peak_voltage_V']:.1f} V of {m['max_voltage_V']:.1f} V",
                  f"- peak current {m['peak_current_A']:.2f} A of {m['peak_current_limit_A']:g} A",
                  f"- i^2 t {m['i2t_A2s']:.1f} A^2 s of the driver's {m['i2t_budget_A2s']:.0f} A^2 s"]
    if s["flat_line"]:
        f = s["flat_line"]
        lines += [f"- flat line, swinging alone: {f['energy_per_m_J']:.1f} J/m of elbow work, "
                  f"{_num(f.get('supply_energy_per_m_J'), '.1f')} J/m from the supply (the "
                  f"motor's losses included), {f['metres_per_min']:.1f} m/min"]
    if s["assumed"]:
        lines += ["", "## Assumed", ""] + [f"- {x}" for x in s["assumed"]]
    lines += ["", "## Plans", "", "| holding | from | incline (deg) | D (m) | solved from "
              "| duration (s) | peak torque (N m) | peak voltage (V) |",
              "| --- | --- | --- | --- | --- | --- | --- | --- |"]
    for p in result.points:
        lines.append(f"| gripper {p.holding}{_by(p)} | {p.start} | "
                     f"{p.incline_deg:+g} | {p.spacing_m:.3f} | "
                     f"{p.how} | "
                     f"{_num(p.duration_s)} | {_num(p.peak_torque_Nm)} | "
                     f"{_num(p.peak_voltage_V, '.1f')} |")
    lines += ["", f"![commissioning]({FIGURE}.{fmt})", ""]
    return "\n".join(lines)


def _landing_lines(studies) -> list[str]:
    """The report's section on how hard the robot lands, a line per study."""
    rows = [st for st in studies if st.impact]
    if not rows:
        return []
    out = ["", "## How hard it lands", "",
           "At each study's capture speed p95, with the robot's effective mass at its gripper "
           "along the planned arrival (both joints free):", ""]
    for st in rows:
        im = st.impact
        out.append(f"- gripper {st.holding}{_by(st)}, {st.incline_deg:+g} deg: "
                   f"{_num(im['capture_speed_mps'])} m/s into {im['effective_mass_kg']:.2f} kg: "
                   f"{_num(im['impact_energy_J'], '.3f')} J, {_num(im['impact_impulse_Ns'], '.3f')} "
                   "N s")
    return out


def write_report(result, out: Path, fmt: str = "png", dpi: int = 150) -> None:
    """``report.md`` and its figure (``commission.FMT`` at ``dpi``) in ``out``."""
    save_figure(result.plot(), Path(out) / f"{FIGURE}.{fmt}", dpi=dpi)
    write_text_atomic(Path(out) / "report.md", report_markdown(result, fmt))
