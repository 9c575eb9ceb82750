"""The same swing with each controller preset and with the true state instead
of the estimate, side by side (data first; :func:`plot_comparison` second)."""
from __future__ import annotations

import dataclasses as dc

from ...params import BplirParams
from .swing_runner import run_swing
from ...plotting import figure_axes, finish
from ...systems.plant import gripper_position

#: (label, controller preset, path mode, estimator in the loop); "auto" is
#: the default (plan tracking with the apex landing for ``plan``)
VARIANTS = (("plan (EKF)", "plan", "auto", True),
            ("plan (true state)", "plan", "auto", False),
            ("plan's QFT loop, path generator (EKF)", "plan", "adaptive", True),
            ("cpfl-qft K=-216, F (EKF)", "cpfl-qft", "adaptive", True),
            ("lab firmware (EKF)", "lab", "lab", True))

COLUMNS = ("outcome", "swing_time_s", "capture_speed_mps", "peak_torque_Nm",
           "peak_motor_power_W", "energy_in_J", "max_estimation_error_rad")


def compare_presets(params: BplirParams, seed: int | None = None) -> list[dict]:
    """The swing of ``params`` with every controller preset, on the estimate and on the true state:
    one row per run with its summary figures."""
    rows = []
    for label, ctrl, mode, est in VARIANTS:
        p = params.with_controller(ctrl)   # the published robots without the line sensor
        p = p.with_(path=dc.replace(p.path, mode=mode))
        r = run_swing(p, seed=seed, use_estimator=est)
        rows.append({"variant": label} | {k: r.summary[k] for k in COLUMNS}
                    | {"_result": r})
    return rows


def comparison_table(rows) -> str:
    """The comparison rows as a Markdown table."""
    head = "| variant | " + " | ".join(COLUMNS) + " |"
    sep = "| --- " * (len(COLUMNS) + 1) + "|"
    lines = [head, sep]
    for r in rows:
        cells = [r["variant"]] + [f"{r[c]:.3g}" if isinstance(r[c], float) else str(r[c])
                                  for c in COLUMNS]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def plot_comparison(rows, axes=None):
    """Elbow angle, torque and gripper path of every run (three axes); returns the figure."""
    fig, ax = figure_axes(axes, 1, 3, figsize=(15, 4.5))
    for r in rows:
        st = r["_result"].logs["state"]
        tp = r["_result"].params.simulated_plant

        gp = [gripper_position(x[:2], tp.l1, tp.l2) for x in st.data]
        ax[0].plot(st.t, st.data[:, 1], label=r["variant"])
        ax[1].plot([g[0] for g in gp], [g[1] for g in gp], label=r["variant"])
        ax[2].plot(r["_result"].logs["torque"].t, r["_result"].logs["torque"].data[:, 0],
                   label=r["variant"])
    ax[0].set_xlabel("time [s]")
    ax[0].set_ylabel("q2 [rad]")
    ax[1].axhline(0, color="k", lw=0.8)
    ax[1].set_xlabel("gripper x [m]")
    ax[1].set_ylabel("gripper y [m]")
    ax[2].set_xlabel("time [s]")
    ax[2].set_ylabel("elbow torque [N m]")
    for a in ax:
        a.grid(True, alpha=0.3)
    ax[0].legend(fontsize=7)
    return finish(fig, "Same swing, different controllers / state source")
