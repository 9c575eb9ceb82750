"""``bplir replay``: a logged torque replayed into the model."""
from __future__ import annotations

from .common import _emit, _in_range, _load_params, _out_dir, _save, _write_json
from .log_options import add_log_options, read_logs
from .options import command, option


def cmd_replay(args) -> int:
    """``bplir replay``: drive the model with a log's torque and compare."""
    import numpy as np

    from ..analysis.identification.torque_replay import replay_torque

    params = _load_params(args)
    _in_range("--threshold", args.threshold, 0.0, 10.0, lo_open=True, unit="rad")
    log, = read_logs(args, params, [args.log])
    # two sampling periods, to the clock's own digits (a 200 Hz log's 0.01 s,
    # not the float sum 0.010000000000000009 of its times' differences)
    least = float(f"{2 * float(np.median(np.diff(log.t))):.9g}")
    _in_range("--window", args.window, least, max(least, 600.0), unit="s")
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


def add_parser(sub) -> None:
    """Declare ``bplir replay`` and its options."""
    p = command(sub, "replay", cmd_replay, "drive the model with a logged elbow torque from the "
                "log's first state; RMSE per joint and the time the model diverges",
                "out/replay")
    p.add_argument("log", help="CSV with t,q1,q2 and tau (N m) or i_cmd (A), optionally "
                   "q1d,q2d (the first row's rates); other names with --columns")
    option(p, "--threshold", float, 0.1, "divergence threshold in rad (default 0.1)")
    option(p, "--window", float, 0.5, "RMSE windows in s (default 0.5)")
    add_log_options(p)
    p.add_argument("--interpolation", choices=("zoh", "linear"), default="zoh",
                   help="the logged torque between samples: held (zoh) or linear")
    p.add_argument("--acrobot", action="store_true",
                   help="also drive Drake's AcrobotPlant (centres of mass on the links' axes, "
                   "viscous damping only) with the torque, beside the model")
