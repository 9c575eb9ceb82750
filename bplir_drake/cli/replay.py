"""``bplir replay``: a logged torque replayed into the model."""
from __future__ import annotations

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
                               torque_sign=args.torque_sign)
    out = _out_dir(args.out)
    res = replay_torque(params, log, threshold=args.threshold, window=args.window)
    summary = res.summary() | {"figure": str(_save(args, res.plot(), out / "replay.png"))}
    _write_json(out / "replay.json", summary)
    td = summary["divergence_time_s"]
    _emit(summary, args.json, [
        f"replayed {summary['samples']} samples ({summary['duration_s']:.2f} s): RMSE q1 "
        f"{summary['rmse_rad'][0]:.4f} rad, q2 {summary['rmse_rad'][1]:.4f} rad",
        f"beyond {args.threshold:g} rad: " + ("never" if td is None else f"at {td:.3f} s"),
        f"files in {out}: replay.png, replay.json"])
    return 0


def add_parser(sub) -> None:
    """Declare ``bplir replay`` and its options."""
    p = command(sub, "replay", cmd_replay, "drive the model with a logged elbow torque from the "
                "log's first state; RMSE per joint and the time the model diverges",
                "out/replay")
    p.add_argument("log", help="CSV with t,q1,q2 and tau (N m) or i_cmd (A), optionally "
                   "q1d,q2d (the first row's rates)")
    option(p, "--threshold", float, 0.1, "divergence threshold in rad (default 0.1)")
    option(p, "--window", float, 0.5, "RMSE windows in s (default 0.5)")
    option(p, "--torque-sign", float, 1.0, "1, or -1 when the log's torque sign is the "
           "opposite of the model's")
