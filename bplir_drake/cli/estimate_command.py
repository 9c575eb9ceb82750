"""``bplir estimate``: the kinematic EKF over an IMU log."""
from __future__ import annotations

from ..plotting import save_figure
from ..io import check_output_file
from .common import InputError, _dpi, _emit, _floats, _in_range, _load_params, _progress
from .options import command, option


# ------------------------------------------------------------------ estimate
def cmd_estimate(args) -> int:
    """``bplir estimate``: run the kinematic EKF over an IMU log."""
    from dataclasses import replace

    from ..analysis.estimation.estimation_plots import plot_estimate_report
    from ..estimation import plot_estimate
    from ..estimation import estimate, read_imu_csv, write_estimate_csv

    params = _load_params(args)
    est = params.estimator.chapter5()   # from an unknown pose
    geo = {k: getattr(args, k) for k in ("r1", "r2", "l1") if getattr(args, k) is not None}
    if geo:
        est = replace(est, **geo)
    if args.period is not None:
        est = replace(est, period=args.period)
    if args.no_bias and args.self_calibrate:
        raise InputError("--no-bias and --self-calibrate exclude each other (the "
                         "self-calibrating filter estimates the gyro biases)")
    if args.no_bias:
        est = replace(est, estimate_bias=False)
    if args.self_calibrate:
        est = est.self_calibrating()
    if args.imu_noise:
        est = est.with_sensor_noise(params.imu)
    _in_range("--calibrate", args.calibrate, 0.0, 3600.0, unit="s")
    x0 = _floats(args.x0, 4, "--x0") if args.x0 else [0.0, 0.0, 0.0, 0.0]
    for opt in ("out", "plot", "report"):
        if getattr(args, opt):
            check_output_file(getattr(args, opt), InputError)
    log = read_imu_csv(args.log)
    res = estimate(log.t, log.samples, est, x0, calibrate_window=args.calibrate,
                   progress=_progress(args), smooth=args.smooth)
    summary = res.summary() | {"geometry": {"r1": est.r1, "r2": est.r2, "l1": est.l1}}
    calibration = []
    if args.self_calibrate:
        from ..analysis.estimation.observability import calibration_identifiability

        calibration = calibration_identifiability(res, est)
        summary["self_calibration"] = calibration
    if args.out:
        summary["estimate_csv"] = str(write_estimate_csv(res, args.out))
    truth, compared = _encoder_comparison(log, res)
    summary |= compared
    if args.plot:
        fig = plot_estimate(res.t, res.x, res.gyro_integral,
                            truth=None if truth is None else truth[:, :2])
        summary["plot"] = str(save_figure(fig, args.plot, dpi=_dpi(args)))
    if args.report:
        summary["report"] = str(save_figure(plot_estimate_report(res, truth=truth), args.report,
                                            dpi=_dpi(args)))
    _emit(summary, args.json, [
        f"estimated {len(res.t)} samples ({summary['duration_s']:.2f} s), "
        f"{res.skipped} isolated NaN rows skipped",
        "final theta1, theta2, omega1, omega2 = "
        + ", ".join(f"{v:.4f}" for v in res.x[-1])]
        + [f"NIS: mean {summary['nis']['mean_nis']:.2f} over {summary['nis']['updates']} "
           f"updates, 95 % band [{summary['nis']['band'][0]:.2f}, "
           f"{summary['nis']['band'][1]:.2f}] "
           + ("(consistent)" if summary["nis"]["consistent"] else "(inconsistent)")]
        + [f"{c['state']}: {c['estimate']:.5g} +/- {c['sigma']:.2g} {c['unit']} "
           f"({c['ratio']:.2f} of the prior's sigma: "
           + ("identified)" if c["identified"] else "not identified by this log)")
           for c in calibration]
        + ([f"the log's encoders lead the IMU by {1e3 * summary['encoder_lead_s']:.1f} ms "
            "(estimated; taken out before comparing): angle RMSE "
            + " / ".join(f"{v:.4f}" for v in summary["angle_rmse_rad"]) + " rad"
            + (", smoothed " + " / ".join(f"{v:.4f}" for v in summary["smoothed_angle_rmse_rad"])
               + " rad" if "smoothed_angle_rmse_rad" in summary else "")]
           if summary.get("encoder_lead_s") is not None else [])
        + [f"{k}: {summary[k]}" for k in ("estimate_csv", "plot", "report") if k in summary])
    return 0


def _encoder_comparison(log, res):
    """(encoder angles on the IMU's clock or None, their lead and the angle
    RMSE of the estimate and of the smoother) when the log has encoders."""
    truth = _logged_truth(log)
    if truth is None:
        return None, {}
    from ..analysis.estimation.filter_study import angle_rmse
    from ..estimation import aligned_truth, encoder_lead

    lead = encoder_lead(log.t, truth, log.samples)   # line the two clocks up
    out = {"encoder_lead_s": lead}
    if lead is not None:
        truth = aligned_truth(log.t, truth, lead)
        out["angle_rmse_rad"] = angle_rmse(res.t, res.x[:, :2], truth[:, :2],
                                           after=0.0).tolist()
        if res.smoothed is not None:
            out["smoothed_angle_rmse_rad"] = angle_rmse(res.t, res.smoothed[:, :2],
                                                        truth[:, :2], after=0.0).tolist()
    return truth, out


def _logged_truth(log):
    """The truth a log may carry (columns theta1, theta2[, omega1, omega2])."""
    import numpy as np

    cols = [c for c in ("theta1", "theta2", "omega1", "omega2") if c in log.extra]
    if cols[:2] != ["theta1", "theta2"]:
        return None
    return np.column_stack([log.extra[c] for c in (cols if len(cols) == 4 else cols[:2])])


def add_parser(sub) -> None:
    """Declare ``bplir estimate`` and its options."""
    p = command(sub, "estimate", cmd_estimate, "run the kinematic EKF over an IMU log (CSV)")
    p.add_argument("log", help="CSV with header t,gyro1,gyro2,acc1_x,acc1_y,acc2_x,acc2_y "
                   "(and optionally encoder angles theta1,theta2[,omega1,omega2]: their lead "
                   "over the IMU is estimated and they are compared on the IMU's clock)")
    for name, what in (("--r1", "IMU 1 distance from joint 1 (m)"),
                       ("--r2", "IMU 2 distance from the elbow (m)"),
                       ("--l1", "link 1 length (m)"), ("--period", "sampling period (s)")):
        option(p, name, float, None, what)
    option(p, "--x0", None, None, "initial T1,T2,W1,W2 (absolute)")
    option(p, "--no-bias", bool, help="no gyro-bias states")
    option(p, "--self-calibrate", bool, help="also estimate each accelerometer's misalignment, "
           "each gyro's scale error and each IMU's distance along its link (states held for "
           "the first 2 s, Heun's second-order step); reports which of them the log identifies")
    option(p, "--imu-noise", bool, help="tune the filter to the IMUs' own noise (the config's "
           "imu.gyro_sigma and imu.accel_sigma, Table 5.1 by default; estimator."
           "datasheet_process_sigma on the accelerometer inputs) instead of (5.39)-(5.40)")
    option(p, "--calibrate", float, 0.0,
           "seconds of stationary data at the start to calibrate gyro bias")
    option(p, "--out", None, None, "estimate CSV to write")
    option(p, "--plot", None, None, "PNG to write")
    option(p, "--smooth", bool, help="also run the Rauch-Tung-Striebel smoother (offline: "
           "uses the whole log); its columns are added beside the causal estimate")
    option(p, "--report", None, None, "PNG report to write: angles, rates, gyro biases "
           "with +/-2 sigma, NIS consistency (and the self-calibration states)",
           metavar="FILE.png")
