"""``bplir calibrate``: fit the plant model to a logged run."""
from __future__ import annotations

from .common import InputError, _emit, _floats, _load_params, _out_dir, _progress, _save, _write_json
from .log_options import add_log_options, read_logs
from .options import command, option


# ------------------------------------------------------------------ calibrate
def cmd_calibrate(args) -> int:
    """``bplir calibrate``: fit the model to a logged run."""
    from ..analysis.identification.deadband import identify_deadband, identify_plant_family
    from ..analysis.identification.fit import (calibrate, check_bounds, cross_validate,
                                               write_calibrated_toml)

    fit = tuple(n.strip() for n in args.fit.split(",") if n.strip())
    twice = sorted({n for n in fit if fit.count(n) > 1})
    if twice:
        raise InputError(f"--fit names {', '.join(twice)} more than once; name each "
                         "parameter once")
    params = _load_params(args)
    bounds = check_bounds(_floats(args.bounds, 2, "--bounds"))
    if args.cv and len(args.log) < 2:
        raise InputError(f"--cv needs at least 2 logs; given {len(args.log)}")
    logs = read_logs(args, params, args.log)
    out_dir = _out_dir(args.out)   # after the logs' checks: a refusal writes nothing
    res = calibrate(params, logs, fit, bounds=bounds, progress=_progress(args))
    summary = res.summary() | {
        "toml": str(write_calibrated_toml(res, out_dir / "calibrated.toml")),
        "plot": str(_save(args, res.plot(), out_dir / "calibration.png"))}
    if args.deadband:
        summary["deadband"] = identify_deadband(res.params)
    if args.family:
        fam = identify_plant_family(res.params)
        summary["plant_family"] = {"ranges": fam.ranges, "fits": fam.fits}
    if args.cv:
        summary["cross_validation"] = cross_validate(params, logs, fit, bounds=bounds).summary()
    _write_json(out_dir / "calibration.json", summary)
    lines = [f"RMSE {res.rmse_before:.4f} -> {res.rmse_after:.4f} rad over {len(logs)} log(s) "
             f"after {res.nfev} simulations"]
    lines += [f"  {n} = {v:.6g} +/- {se:.2g}" + ("  (at its bound)" if n in res.at_bound else "")
              for n, v, se in zip(res.names, res.values, res.std_errors)]
    if args.cv:
        cv = summary["cross_validation"]
        lines.append(f"cross-validation (each log left out in turn): held-out RMSE "
                     f"{cv['mean_held_out_rmse_before_rad']:.4f} -> "
                     f"{cv['mean_held_out_rmse_after_rad']:.4f} rad")
    lines.append(f"calibrated parameters: {summary['toml']} (use with --config)")
    _emit(summary, args.json, lines)
    return 0


def add_parser(sub) -> None:
    """Declare ``bplir calibrate`` and its options."""
    p = command(sub, "calibrate", cmd_calibrate, "fit the plant model to a logged run (4.5)",
                "out/calibration")
    p.add_argument("log", nargs="+", help="CSV with t,q1,q2 and tau (N m) or i_cmd (A); "
                   "several logs are fitted jointly")
    option(p, "--fit", None, "fv1,fv2,fc1,fc2",
           "parameters to fit (fv1,fv2,fc1,fc2,I1,I2,lc1,lc2,m1,m2)")
    add_log_options(p)
    option(p, "--bounds", None, "0.1,10", "LOW,HIGH: masses and inertias are fitted within "
           "these factors of their starting values (default 0.1,10)")
    option(p, "--cv", bool, help="also cross-validate: fit all logs but one, each in turn, and "
           "report the RMSE on the one left out")
    option(p, "--deadband", bool, help="also identify the dead-band of the calibrated model (4.6)")
    option(p, "--family", bool,
           help="also identify the CPFL plant family of the calibrated model (4.7)")

