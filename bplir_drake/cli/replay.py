"""``bplir replay``: a logged torque replayed into the model."""
from __future__ import annotations

import math

from .common import InputError, _emit, _in_range, _load_params, _out_dir, _save, _write_json
from .options import command, option


def cmd_replay(args) -> int:
    """``bplir replay``: drive the model with a log's torque and compare."""
    from ..analysis.identification.calibration import read_calibration_csv
    from ..analysis.identification.torque_replay import replay_torque

    params = _load_params(args)
    _in_range("--threshold", args.threshold, 0.0, 10.0, lo_open=True, unit="rad")
    _in_range("--window", args.window, 0.0, 600.0, lo_open=True, unit="s")
    if args.torque_sign not in (-1.0, 1.0):
        raise InputError(f"--torque-sign = {args.torque_sign:g} must be 1 or -1")
    log = read_calibration_csv(args.log, params.motor.torque_per_amp, min_duration=0.2,
                               torque_sign=args.torque_sign, columns=_columns(args.columns),
                               span=_span(args.span))
    if args.angles == "robot":
        if not params.robot.file:
            raise InputError("--angles robot needs a robot description (robot.file); "
                             "allowed: package without one")
        from ..analysis.identification.calibration import in_package_angles
        from ..params.robot_file import describe_robot

        log = in_package_angles(log, describe_robot(params.robot))
    out = _out_dir(args.out)
    res = replay_torque(params, log, threshold=args.threshold, window=args.window,
                        interpolation=args.interpolation, acrobot=args.acrobot)
    summary = res.summary() | {"figure": str(_save(args, res.plot(), out / "replay.png"))}
    _write_json(out / "replay.json", summary)
    _emit(summary, args.json, [
        f"replayed {summary['samples']} samples ({summary['duration_s']:.2f} s): RMSE q1 "
        f"{summary['rmse_rad'][0]:.4f} rad, q2 {summary['rmse_rad'][1]:.4f} rad, beyond "
        f"{args.threshold:g} rad {_when(summary['divergence_time_s'])}"]
        + ([f"Drake AcrobotPlant: RMSE q1 {summary['acrobot']['rmse_rad'][0]:.4f} rad, q2 "
            f"{summary['acrobot']['rmse_rad'][1]:.4f} rad, beyond {args.threshold:g} rad "
            f"{_when(summary['acrobot']['divergence_time_s'])}; at most "
            f"{summary['acrobot']['largest_difference_from_model_rad']:.2g} rad from the model"]
           if args.acrobot else [])
        + [f"files in {out}: replay.png, replay.json"])
    return 0


def _when(t) -> str:
    return "never" if t is None else f"at {t:.3f} s"


def _columns(text):
    """``--columns`` as {our name: the file's}: ``t=meas_time,q1=...``."""
    if not text:
        return None
    out = {}
    for item in text.split(","):
        ours, eq, theirs = (s.strip() for s in item.partition("="))
        if not (eq and ours and theirs):
            raise InputError(f"--columns '{item}' must be name=column (e.g. t=meas_time)")
        out[ours] = theirs
    return out


def _span(text):
    """``--span START,END`` (s of the log's clock) as a pair."""
    if not text:
        return None
    try:
        start, end = (float(v) for v in text.split(","))
    except ValueError:
        raise InputError(f"--span '{text}' must be START,END in s (e.g. 0.5,2.0)") from None
    if not (math.isfinite(start) and math.isfinite(end) and start < end):
        raise InputError(f"--span {text}: allowed finite START < END")
    return start, end


def add_parser(sub) -> None:
    """Declare ``bplir replay`` and its options."""
    p = command(sub, "replay", cmd_replay, "drive the model with a logged elbow torque from the "
                "log's first state; RMSE per joint and the time the model diverges",
                "out/replay")
    p.add_argument("log", help="CSV with t,q1,q2 and tau (N m) or i_cmd (A), optionally "
                   "q1d,q2d (the first row's rates); other names with --columns")
    option(p, "--threshold", float, 0.1, "divergence threshold in rad (default 0.1)")
    option(p, "--window", float, 0.5, "RMSE windows in s (default 0.5)")
    option(p, "--torque-sign", float, 1.0, "1, or -1 when the log's torque sign is the "
           "opposite of the model's")
    option(p, "--columns", str, None, "the log's names of its columns, e.g. "
           "t=meas_time,q1=shoulder_meas_pos,q2=elbow_meas_pos,tau=elbow_meas_tau "
           "(names: t, q1, q2, q1d, q2d, tau, i_cmd)")
    p.add_argument("--angles", choices=("package", "robot"), default="package",
                   help="the log's angles, rates and torque are the package's, or the joint "
                   "coordinates of the robot description (robot.file)")
    p.add_argument("--interpolation", choices=("zoh", "linear"), default="zoh",
                   help="the logged torque between samples: held (zoh) or linear")
    option(p, "--span", str, None, "START,END: replay this stretch of the log's clock (s)")
    p.add_argument("--acrobot", action="store_true",
                   help="also drive Drake's AcrobotPlant (centres of mass on the links' axes, "
                   "viscous damping only) with the torque, beside the model")
