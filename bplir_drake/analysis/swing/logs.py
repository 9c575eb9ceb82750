"""A swing's logs as a table: the columns of the CSV export (state, estimate, command, motor), the gripper's speed along the swing."""
from __future__ import annotations

from pathlib import Path
import numpy as np
from ...io import atomic_path
from ...params import BplirParams
from ...simulate import Log, logs
from ...systems.plant import gripper_position, gripper_velocity, kinetic_energy, potential_energy
from ...systems.motor import back_emf, torque_window


LOG_COLUMNS = ("t", "q1", "q2", "q1d", "q2d", "q1_est", "q2_est", "q1d_est", "q2d_est",
               "q2_ref", "torque_cmd", "torque", "power", "current", "f1", "f2",
               "gripper_x", "gripper_y", "gripper_along", "gripper_above",
               "kinetic", "potential", "energy",
               "voltage", "back_emf", "electrical_power", "torque_available_lo",
               "torque_available_hi")


def log_table(result: SwingResult) -> tuple[list[str], np.ndarray]:
    """(column names, table) of a swing's logs on the state's time grid: truth, estimate,
    reference, torques, power, current, friction, gripper position (x
    horizontal and y up, and along and above the inclined line, from the
    holding gripper) and energies (:data:`LOG_COLUMNS`)."""
    lg, p = result.logs, result.params
    st = lg["state"]
    t, x = st.t, st.data
    est = lg["estimate"].at(t)
    ref = lg["reference"].at(t) if "reference" in lg else np.full((len(t), 1), np.nan)
    cmd = lg["command"].at(t)
    tp = p.simulated_plant
    gp = np.array([gripper_position(r[:2], tp.l1, tp.l2) for r in x])
    alpha = np.radians(p.scenario.incline_deg)   # the line's frame: along it, and above it
    line = np.c_[gp @ [np.cos(alpha), np.sin(alpha)], gp @ [-np.sin(alpha), np.cos(alpha)]]
    ke = np.array([kinetic_energy(r[:2], r[2:], tp) for r in x])
    pe = np.array([potential_energy(r[:2], tp) for r in x])
    fr = -lg["friction"].data
    cols = [t[:, None], x, est, ref, cmd, lg["torque"].data, lg["power"].data, lg["current"].data,
            fr, gp, line, ke[:, None], pe[:, None], (ke + pe)[:, None], motor_columns(p, lg, x)]
    return list(LOG_COLUMNS), np.hstack(cols)


def motor_columns(p: BplirParams, lg: dict[str, Log], x) -> np.ndarray:
    """(N, 5) on the state's grid: winding voltage, back-EMF, electrical
    power, and the lowest and highest torque the motor could deliver at
    that instant (voltage envelope at the true elbow rate, the driver's
    present current limit, the torque saturation)."""

    m, t = p.motor, lg["state"].t
    limit = min(p.controller.torque_limit, m.torque_limit)
    tripped = lg["tripped"].at(t)[:, 0] > 0.5 if "tripped" in lg else np.zeros(len(t), bool)
    window = np.array([torque_window(float(r[3]), m, m.i_cont if tr else m.i_peak, limit)
                       for r, tr in zip(x, tripped)]).reshape(len(t), 2)
    nan = np.full((len(t), 1), np.nan)
    volt = lg["voltage"].at(t) if "voltage" in lg else nan
    elec = lg["electrical_power"].at(t) if "electrical_power" in lg else nan
    return np.hstack([volt, back_emf(x[:, 3:4], m), elec, window])


def write_log_csv(result: SwingResult, path) -> Path:
    """The :func:`log_table` as CSV at ``path`` (atomic)."""
    cols, data = log_table(result)
    path = Path(path)
    with atomic_path(path) as tmp:
        np.savetxt(tmp, data, delimiter=",", header=",".join(cols), comments="", fmt="%.7g")
    return path


def gripper_speed(result: SwingResult) -> np.ndarray:
    """Free-gripper speed (m/s) at each logged state."""
    tp = result.params.simulated_plant
    return np.array([np.linalg.norm(gripper_velocity(r[:2], r[2:], tp.l1, tp.l2))
                     for r in result.logs["state"].data])
