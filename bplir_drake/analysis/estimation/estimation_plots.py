"""Plots of the estimation studies."""
from __future__ import annotations

import numpy as np

from ...plotting import figure_axes, finish


def plot_observability(result, axes=None):
    """Relative smallest singular value of O (gyro-only and full) against time,
    with the (5.17) points marked, and the entries a31, a42."""
    fig, axes = figure_axes(axes, 2, 1, figsize=(9, 6), sharex=True)
    ax = axes[0]
    ax.semilogy(result.t, result.smin_gyro, label="gyro only (5.16)")
    ax.semilogy(result.t, result.smin_full, label="gyro + accelerometer (5.18)")
    ax.axhline(result.threshold, color="grey", ls="--", lw=0.8, label="rank threshold")
    for e in result.events:
        ax.axvline(e["t"], color="C3", lw=0.6, alpha=0.6)
    ax.set_ylabel("sigma_min / sigma_max")
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(True, alpha=0.3)
    ax = axes[1]
    ax.plot(result.t, result.a31, label="a31 = -g c1/r1")
    ax.plot(result.t, result.a42, label="a42 = d(omega2')/d(theta2)")
    ax.axhline(0, color="k", lw=0.6)
    ax.set_ylabel("A entries [1/s^2]")
    ax.set_xlabel("time [s]")
    ax.legend(loc="upper right", fontsize=8)
    ax.grid(True, alpha=0.3)
    return finish(fig, "Observability along the swing (red: gyro-only rank loss, (5.17))")


def plot_estimate_report(result, axes=None, *, truth=None, title="Estimation report"):
    """What a user wants of a log (``result``: an
    :class:`~bplir_drake.estimation.EstimateResult`): both angles and both
    rates (filter, smoother when run, gyro integral, truth when known), the
    estimated gyro biases with their +/-2 sigma bands, and the normalised
    innovation squared (a 1 s moving mean) against its 95 % band with the
    whole log's consistency verdict; with self-calibration states a fourth
    row: the accelerometer misalignments, the gyro scale errors and the IMU
    distances, each with +/-2 sigma.  Six or eight axes (3 or 4 x 2);
    returns the figure."""
    t = result.t
    layout = result.layout or ({"bias": slice(4, 6)} if result.cov_diag.shape[1] > 4 else {})
    calib = any(g in layout for g in ("misalign", "scale", "position"))
    fig, ax = figure_axes(axes, 4 if calib else 3, 2, figsize=(12, 12 if calib else 9),
                          sharex=True)
    for i in range(2):
        for row, col, label, unit in ((0, i, f"theta{i + 1}", "rad"),
                                      (1, i, f"omega{i + 1}", "rad/s")):
            a = ax[row, col]
            j = i + 2 * row
            if truth is not None and truth.shape[1] > j:
                a.plot(t, truth[:, j], "k", lw=2.2, alpha=0.35, label="truth")
            a.plot(t, result.x[:, j], "C0", lw=1, label="filter (causal)")
            if result.smoothed is not None:
                a.plot(t, result.smoothed[:, j], "C2", lw=1, label="RTS smoother")
            if row == 0:
                a.plot(t, result.gyro_integral[:, i], "C3--", lw=0.8, label="gyro integral (5.41)")
            a.set_ylabel(f"{label} [{unit}]")
            a.legend(loc="upper right", fontsize=7)
    a = ax[2, 0]
    if "bias" in layout:
        for i in range(2):
            b = result.gyro_bias[:, i]
            sd = 2 * np.sqrt(result.cov_diag[:, layout["bias"].start + i])
            a.plot(t, b, f"C{i}", label=f"bias {i + 1}")
            a.fill_between(t, b - sd, b + sd, color=f"C{i}", alpha=0.2, lw=0)
        a.legend(loc="upper right", fontsize=7)
    else:
        a.text(0.5, 0.5, "no bias states (--no-bias)", ha="center", transform=a.transAxes)
    a.set_ylabel("gyro bias ±2σ [rad/s]")
    a = ax[2, 1]
    nis = result.nis
    ok = np.isfinite(nis)
    period = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    w = max(1, int(round(1.0 / period)))
    moving = np.convolve(np.where(ok, nis, 0.0), np.ones(w), "same") / np.maximum(
        np.convolve(ok.astype(float), np.ones(w), "same"), 1)
    check = result.nis_check()
    a.plot(t, moving, "C0", lw=1, label="NIS, 1 s mean")
    a.axhline(4.0, color="k", lw=0.8, label="expected (4 measurements)")
    for v in check["band"]:
        a.axhline(v, color="grey", lw=0.6, ls="--")
    a.set_ylabel("NIS")
    a.set_title(f"whole log: mean NIS {check['mean_nis']:.2f}, 95 % band "
                f"[{check['band'][0]:.2f}, {check['band'][1]:.2f}]: "
                + ("consistent" if check["consistent"] else "inconsistent"), fontsize=9)
    a.legend(loc="upper right", fontsize=7)
    if calib:
        _plot_calibration_states(result, layout, ax[3])
    for a in ax.flat:
        a.grid(True, alpha=0.3)
    for a in ax[-1]:
        a.set_xlabel("time [s]")
    return finish(fig, title)


def _band(a, t, value, sd2, color, label):
    a.plot(t, value, color, lw=1, label=label)
    a.fill_between(t, value - sd2, value + sd2, color=color, alpha=0.2, lw=0)


def _plot_calibration_states(result, layout, ax):
    """Misalignments (deg) on ``ax[0]``; gyro scale errors (%) on ``ax[1]``
    and the IMU distances (mm from the filter's geometry at the start) on a
    second axis of it; all with +/-2 sigma."""
    t = result.t
    var = result.cov_diag
    a = ax[0]
    if "misalign" in layout:
        for i in range(2):
            _band(a, t, np.degrees(result.misalignment[:, i]),
                  2 * np.degrees(np.sqrt(var[:, layout["misalign"].start + i])), f"C{i}",
                  f"accelerometer {i + 1}")
        a.legend(loc="upper right", fontsize=7)
    a.set_ylabel("misalignment ±2σ [deg]")
    a = ax[1]
    if "scale" in layout:
        for i in range(2):
            _band(a, t, 100 * result.gyro_scale[:, i],
                  200 * np.sqrt(var[:, layout["scale"].start + i]), f"C{i}", f"gyro {i + 1} scale")
        a.set_ylabel("gyro scale error ±2σ [%]")
        a.legend(loc="upper left", fontsize=7)
    if "position" in layout:
        b = a.twinx()
        for i in range(2):
            r = result.imu_position[:, i]
            _band(b, t, 1e3 * (r - r[0]), 2e3 * np.sqrt(var[:, layout["position"].start + i]),
                  f"C{i + 2}", f"IMU {i + 1} distance")
        b.set_ylabel("IMU distance - start ±2σ [mm]")
        b.legend(loc="upper right", fontsize=7)
