"""The ``bplir`` command line.

Every sub-command accepts ``--preset NAME`` and ``--config FILE.toml``.  Bad
input (parameters, files, scenarios) prints one line ``bplir: error: ...``
to stderr and exits with status 2.
"""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from .analysis.identification.calibration import CalibrationError
from .analysis.control.errors import QftError
from .analysis.plotting import save_figure
from .estimation import LogError
from .io import (atomic_path, package_version, check_output_dir, check_output_file, dumps_strict,
                 write_json_atomic, write_text_atomic)
from .params import ParameterError


class InputError(ValueError):
    """Bad user input that is not a parameter (malformed log, bad option value)."""


class _Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, status 2
        sys.stderr.write(f"bplir: error: {message}\n")
        sys.exit(2)


def _floats(text: str, n: int, name: str) -> list[float]:
    try:
        vals = [float(v) for v in text.split(",")]
    except ValueError:
        raise InputError(f"{name} = '{text}' must be {n} comma-separated numbers") from None
    if len(vals) != n or not all(math.isfinite(v) for v in vals):
        raise InputError(f"{name} = '{text}' must be {n} finite comma-separated numbers")
    return vals


def _load_params(args):
    from .params import load_toml, preset

    if getattr(args, "config", None):
        if args.preset:  # the file's tables override the named preset
            from .params import from_dict, read_toml

            params = from_dict(read_toml(args.config) | {"preset": args.preset})
        else:
            params = load_toml(args.config)
    else:
        params = preset(args.preset or "dissertation")
    return _with_settings(_with_hardware(params, args), args)


def _with_settings(params, args):
    """``params`` with every ``--set block.field=value`` (a TOML value;
    bare words are strings)."""
    import tomllib

    from .params import BLOCKS, ParameterError

    for item in getattr(args, "set", None) or []:
        key, sep, text = item.partition("=")
        block, dot, name = key.strip().partition(".")
        if not (sep and dot and block and name):
            raise InputError(f"--set '{item}' must be block.field=value (e.g. plant.m2=1.6)")
        if block not in BLOCKS:
            raise ParameterError(f"--set {key}: unknown block '{block}'; allowed: "
                                 + ", ".join(BLOCKS))
        try:
            value = tomllib.loads(f"v = {text.strip()}")["v"]
        except tomllib.TOMLDecodeError:
            value = text.strip()
        base = getattr(params, block)
        if base is None:   # true_plant / true_friction start from the nominal blocks
            base = getattr(params, block.removeprefix("true_"))
        params = params.with_(**{block: BLOCKS[block].from_dict({name: value}, base=base)})
    return params


def _with_hardware(params, args):
    """``params`` with the ``--hardware`` options (comma-separated names)."""
    names = [n.strip() for n in (getattr(args, "hardware", None) or "").split(",") if n.strip()]
    return params.with_hardware(*names) if names else params


#: figure formats every drawing command writes (``--format``)
FIGURE_FORMATS = ("png", "pdf", "svg")


def _dpi_value(text: str) -> int:
    """``--dpi``'s value: a whole number in [30, 1200]."""
    try:
        dpi = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--dpi = '{text}' must be a whole number") from None
    if not 30 <= dpi <= 1200:
        raise argparse.ArgumentTypeError(f"--dpi = {dpi} is out of range; allowed [30, 1200]")
    return dpi


def _dpi(args) -> int:
    """``--dpi``, checked (raster resolution; vector formats keep it for their images)."""
    dpi = getattr(args, "dpi", None) or 150
    _in_range("--dpi", dpi, 30, 1200)
    return dpi


def _save(args, fig, path) -> Path:
    """Save ``fig`` at ``path`` with the suffix of ``--format`` and ``--dpi``."""
    fmt = getattr(args, "format", None) or "png"
    return save_figure(fig, Path(path).with_suffix("." + fmt), dpi=_dpi(args))


class Terminated(KeyboardInterrupt):
    """SIGTERM or SIGHUP, handled like Ctrl-C (temporary files removed,
    finished rows kept), with the exit status ``128 + signal``."""

    def __init__(self, signum: int):
        super().__init__(signum)
        self.signum = signum


def _terminate(signum, frame):
    raise Terminated(signum)


#: where the command's own output goes: standard output as ``main`` found it
#: (with ``--json`` everything else printed meanwhile -- a plug-in's
#: chatter -- goes to standard error, so standard output stays JSON)
_OUT = [None]


def _emit(obj, as_json: bool, text_lines) -> None:
    """Print ``obj`` as strict JSON (NaN and infinities as null) or the text."""
    out = _OUT[0] or sys.stdout
    if as_json:
        print(dumps_strict(obj), file=out)
    else:
        for line in text_lines:
            print(line, file=out)


def _write_json(path, obj) -> str:
    """Write ``obj`` as strict JSON, atomically; returns the path as text."""
    return str(write_json_atomic(path, obj))


def _progress(args) -> bool:
    """Show progress bars: standard error is a terminal and ``--json`` is off."""
    return not getattr(args, "json", False) and sys.stderr.isatty()


def _out_dir(path) -> Path:
    """The output directory, created and proven writable before any work."""
    if not str(path).strip():
        raise InputError("--out '' is empty; name an output directory")
    return check_output_dir(path, InputError)


def _in_range(name: str, value, lo: float, hi: float, *, lo_open: bool = False,
              hi_open: bool = False, unit: str = "") -> None:
    """Raise InputError unless ``lo <(=) value <(=) hi`` (finite)."""
    ok = isinstance(value, (int, float)) and math.isfinite(value) and \
        (value > lo if lo_open else value >= lo) and (value < hi if hi_open else value <= hi)
    if not ok:
        left, right = "(" if lo_open else "[", ")" if hi_open else "]"
        u = f" {unit}" if unit else ""

        def fmt(v):   # whole numbers in full (a seed's 4294967295, not 4.29497e+09)
            return str(v) if isinstance(v, int) and not isinstance(v, bool) else f"{v:g}"

        shown = fmt(value) if isinstance(value, (int, float)) else repr(value)
        raise InputError(f"{name} = {shown}{u} is out of range; allowed "
                         f"{left}{fmt(lo)}, {fmt(hi)}{right}{u}")


# ------------------------------------------------------------------ model
def cmd_model(args) -> int:
    """``bplir model``: minimum pendulum period, Table 4.1, hanging eigenvalues."""
    from .analysis.model.friction_table import PUBLISHED_TABLE_4_1, friction_table, published_setup
    from dataclasses import replace

    from .analysis.model.envelope import torque_envelope
    from .analysis.model.linearization import hanging_linearization
    from .analysis.model.pendulum import pendulum_periods
    from .analysis.swing import run_swing
    from .params import to_dict

    params = _load_params(args)
    out_dir = _out_dir(args.out)
    if args.incline is not None:
        params = params.with_(scenario=replace(params.scenario, incline_deg=args.incline))
    per = pendulum_periods(params.plant)
    fr = params.friction
    t_elbow = friction_table(fr.fc2, fr.b, 40.0)
    t_pub = published_setup(fr.b)
    lin = hanging_linearization(params)
    wn, zeta = lin.modes()
    swing = None if args.no_swing else run_swing(params)
    env = torque_envelope(params, swing=swing)
    out = {
        "T_min_s": per.T_min_printed,
        "T_min_note": "(6.14) as printed uses l1 + lc2: the links straight (q2 = 0), "
                      "the largest CoM radius, not the folded robot",
        "T_folded_s": per.T_folded,
        "T_compound_straight_s": per.T_straight_compound,
        "friction_rmse_candidate": t_elbow.rmse_candidate,
        "friction_rmse_viscous": t_elbow.rmse_viscous,
        "friction_rmse_setup": {"joint": "elbow", "fc_Nm": t_elbow.fc, "b_rad_s": t_elbow.b,
                                "velocity_range_rad_s": [-t_elbow.vmax, t_elbow.vmax]},
        "friction_rmse_published": PUBLISHED_TABLE_4_1,
        "friction_rmse_published_setup": {
            "fc_Nm": t_pub.fc, "velocity_range_rad_s": [-t_pub.vmax, t_pub.vmax],
            "rmse_candidate": t_pub.rmse_candidate, "rmse_viscous": t_pub.rmse_viscous},
        "hanging_eigenvalues": [[float(z.real), float(z.imag)] for z in lin.eigenvalues],
        "hanging_modes": [{"wn_rad_s": float(w), "zeta": float(z)} for w, z in zip(wn, zeta)],
        "torque_per_amp_Nm_A": params.motor.torque_per_amp,
        "envelope": env.summary(),
        "files": {"envelope": str(_save(args, env.plot(), out_dir / "envelope.png"))},
        "parameters": to_dict(params),
    }
    lines = [
        f"T_min (6.14 as printed, links straight) = {per.T_min_printed:.3f} s; "
        f"folded (q2 = pi) = {per.T_folded:.3f} s",
        f"Table 4.1 elbow over +/-40 rad/s: candidate RMSE {t_elbow.rmse_candidate:.4f} N m, "
        f"viscous-only {t_elbow.rmse_viscous:.4f} N m",
        f"  published 0.0272 / 0.35 reproduced by fc = {t_pub.fc} N m over "
        f"+/-{t_pub.vmax} rad/s: {t_pub.rmse_candidate:.4f} / {t_pub.rmse_viscous:.4f}",
        "hanging eigenvalues: " + ", ".join(f"{z.real:.4g}{z.imag:+.4g}j" for z in lin.eigenvalues),
        f"motor at {env.supply_voltage:g} V: no-load elbow rate {env.no_load_speed:.1f} rad/s, "
        f"full current up to {env.corner_speed():.1f} rad/s, at most {env.max_power():.0f} W",
        f"envelope figure: {out['files']['envelope']}",
    ]
    _emit(out, args.json, lines)
    return 0


# ------------------------------------------------------------------ params
def cmd_params(args) -> int:
    """``bplir params``: the parameter reference with the values in force."""
    from .params import parameter_reference

    params = _load_params(args)
    rows = parameter_reference([args.block] if args.block else None)
    for r in rows:
        r["default"] = getattr(getattr(params, r["block"]), r["name"])
    if args.json:
        _emit({"parameters": [dict(r, value=r.pop("default")) for r in rows]}, True, [])
        return 0
    width = max(len(f"{r['block']}.{r['name']}") for r in rows)
    def shown(v):
        return f"{v:.6g}" if isinstance(v, float) else str(v)

    lines = [f"{r['block'] + '.' + r['name']:<{width}}  {shown(r['default']):<12} "
             f"{r['unit']:<10} {r['range']:<16} {r['doc']}" for r in rows]
    _emit(None, False, lines)
    return 0


# ------------------------------------------------------------------ freeswing
def cmd_freeswing(args) -> int:
    """``bplir freeswing``: simulate a free swing, write its plot and summary."""
    from .analysis.model.freeswing import simulate_free_swing

    params = _load_params(args)
    q0 = _floats(args.q0, 2, "--q0")
    for name, q in zip(("--q0 Q1", "--q0 Q2"), q0):   # an angle, not any number
        _in_range(name, q, -2 * math.pi, 2 * math.pi, unit="rad")
    _in_range("--duration", args.duration, 0.0, 600.0, lo_open=True, unit="s")
    _in_range("--torque", args.torque, -100.0, 100.0, unit="N m")
    out_dir = _out_dir(args.out)
    res = simulate_free_swing(params, q0, args.duration, elbow_torque=args.torque,
                              friction=not args.no_friction, log_period=0.005)
    plot = _save(args, res.plot(), out_dir / "freeswing.png")
    summary = res.summary() | {"plot": str(plot), "friction": not args.no_friction,
                               "elbow_torque_Nm": args.torque}
    _write_json(out_dir / "freeswing.json", summary)
    _emit(summary, args.json, [
        f"energy at start {res.energy_start:.4f} J, at end {res.energy_end:.4f} J "
        f"(change {res.energy_end - res.energy_start:+.4f} J)", f"plot: {plot}"])
    return 0


# ------------------------------------------------------------------ estimate
def cmd_estimate(args) -> int:
    """``bplir estimate``: run the kinematic EKF over an IMU log."""
    from dataclasses import replace

    from .analysis.estimation.plots import plot_estimate, plot_estimate_report
    from .estimation import estimate, read_imu_csv, write_estimate_csv

    params = _load_params(args)
    est = params.estimator
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
    summary = {"samples": int(len(res.t)), "duration_s": float(res.t[-1] - res.t[0]),
               "skipped_updates": res.skipped,
               "final_estimate": res.x[-1].tolist(),
               "final_gyro_bias": res.gyro_bias[-1].tolist(),
               "nis": res.nis_check(),
               "geometry": {"r1": est.r1, "r2": est.r2, "l1": est.l1}}
    if args.smooth:
        summary["smoothed_start"] = res.smoothed[0].tolist()
    calibration = []
    if args.self_calibrate:
        from .analysis.estimation.observability import calibration_identifiability

        calibration = calibration_identifiability(res, est)
        summary["self_calibration"] = calibration
    if args.out:
        summary["estimate_csv"] = str(write_estimate_csv(res, args.out))
    truth = _logged_truth(log)
    if truth is not None:   # encoders in the log: line their clock up with the IMU's
        from .analysis.estimation.study import angle_rmse
        from .estimation import aligned_truth, encoder_lead

        lead = encoder_lead(log.t, truth, log.samples)
        summary["encoder_lead_s"] = lead
        if lead is not None:
            truth = aligned_truth(log.t, truth, lead)
            summary["angle_rmse_rad"] = angle_rmse(res.t, res.x[:, :2], truth[:, :2],
                                                   after=0.0).tolist()
            if args.smooth:
                summary["smoothed_angle_rmse_rad"] = angle_rmse(
                    res.t, res.smoothed[:, :2], truth[:, :2], after=0.0).tolist()
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


def _logged_truth(log):
    """The truth a log may carry (columns theta1, theta2[, omega1, omega2])."""
    import numpy as np

    cols = [c for c in ("theta1", "theta2", "omega1", "omega2") if c in log.extra]
    if cols[:2] != ["theta1", "theta2"]:
        return None
    return np.column_stack([log.extra[c] for c in (cols if len(cols) == 4 else cols[:2])])


# ------------------------------------------------------------------ observability
def cmd_observability(args) -> int:
    """``bplir observability``: observability of the kinematic model along a swing."""
    from .analysis.estimation.study import simulate_estimation
    from .analysis.estimation.observability import observability_along, plant_gyro_observability
    from .systems.plant import initial_configuration

    params = _load_params(args)
    _in_range("--duration", args.duration, 0.0, 60.0, lo_open=True, unit="s")
    _in_range("--torque", args.torque, -100.0, 100.0, unit="N m")
    _in_range("--threshold", args.threshold, 0.0, 1.0, lo_open=True, hi_open=True)
    out_dir = _out_dir(args.out)
    q0 = initial_configuration(params.scenario.grip_spacing, params.plant)
    run_ = simulate_estimation(params, q0=q0, duration=args.duration, knock=None,
                               elbow_torque=((0.0, 1.0), (0.0, args.torque)))
    u = run_.imu[:, [2, 4]]
    res = observability_along(run_.t, run_.truth, u, params.estimator, threshold=args.threshold)
    out = res.summary() | {"drake_is_observable_plant": plant_gyro_observability(params),
                           "scenario": {"q0": list(map(float, q0)), "duration_s": args.duration,
                                        "elbow_torque_Nm_after_1s": args.torque}}
    out["plot"] = str(_save(args, res.plot(), out_dir / "observability.png"))
    _write_json(out_dir / "observability.json", out)
    n_loss = sum(1 for e in res.events if e["rank_gyro"] < 4)
    _emit(out, args.json, [
        f"min rank gyro-only {out['min_rank_gyro_only']}, full {out['min_rank_full']} "
        f"(threshold {res.threshold:g}); full-rank fraction gyro-only "
        f"{out['full_rank_fraction_gyro_only']:.3f}, full {out['full_rank_fraction_full']:.3f}",
        f"gyro-only loses rank at {n_loss} points where a31 or a42 vanish (5.17)",
        f"plot: {out['plot']}"])
    return 0


# ------------------------------------------------------------------ qft
def cmd_qft(args) -> int:
    """``bplir qft``: verify (or design) the outer loop on a plant family."""
    from .analysis.control.report import qft_report

    params = _load_params(args)
    if args.family == "diagram":
        _in_range("--plants", args.plants, 2, 10000)
        _in_range("--seed", args.seed, 0, 2 ** 32 - 1)
    out_dir = _out_dir(args.out)
    res = qft_report(params, args.controller, family=args.family, plants=args.plants,
                     seed=args.seed, design=args.design, progress=_progress(args))
    report, ver, fam_plot = res.report, res.verification, res.family
    figs = {name.split(".")[0]: _save(args, fig, out_dir / name)
            for name, fig in res.figures().items()}
    report["figures"] = {k: str(v) for k, v in figs.items()}
    _write_json(out_dir / "qft.json", report)
    lines = [f"family: {fam_plot.name}, {len(fam_plot)} plants, controller {report['controller']}"]
    for name, c in ver.checks.items():
        lines.append(f"  {name}: {'holds' if c['holds'] else 'FAILS'} (worst {c['worst']:.4g}, "
                     f"limit {c['limit']:.4g})")
    if args.family == "dissertation":
        m = report["largest_delay_published_K_keeps_stable"]
        lines.append(f"  with Td in [0.15, 0.3] s: all specs hold: "
                     f"{report['with_delay_0.15_0.3_s']['all_hold']}; largest delay K = -216 "
                     f"keeps every plant stable: {m['largest_delay_all_plants_s']:.4f} s")
    lines.append(f"figures in {out_dir}")
    _emit(report, args.json, lines)
    return 0


# ------------------------------------------------------------------ swing
def _with_path_mode(params, mode, law=None):
    """``params`` with ``path.mode`` set from ``--path-mode`` and
    ``path.landing_law`` from ``--landing-law`` (None: kept)."""
    import dataclasses as dc

    from .params import LANDING_LAWS, PATH_MODES

    if mode is not None:
        if mode not in PATH_MODES:
            raise InputError(f"--path-mode = '{mode}' is unknown; allowed: "
                             + ", ".join(PATH_MODES))
        params = params.with_(path=dc.replace(params.path, mode=mode))
    if law is not None:
        if law not in LANDING_LAWS:
            raise InputError(f"--landing-law = '{law}' is unknown; allowed: "
                             + ", ".join(LANDING_LAWS))
        params = params.with_(path=dc.replace(params.path, landing_law=law))
    return params


def _swing_params(args):
    import dataclasses as dc

    params = _load_params(args)
    sc = params.scenario
    changes = {}
    if args.incline is not None:
        changes["incline_deg"] = args.incline
    if args.seed is not None:
        changes["seed"] = args.seed
    if args.true_state:
        changes["use_estimator"] = False
    try:
        sc = dc.replace(sc, **changes)
    except TypeError as exc:  # pragma: no cover - defensive
        raise InputError(str(exc)) from None
    params = params.with_(scenario=sc)
    if args.controller:
        params = params.with_controller(args.controller)
    if args.estimator:
        params = params.with_estimator(args.estimator)
    params = _with_path_mode(params, getattr(args, "path_mode", None),
                             getattr(args, "landing_law", None))
    from .diagrams import swing_geometry

    swing_geometry(params)  # validates grip spacing / incline for this robot
    _check_plugin(params)   # a broken plug-in is refused before anything is written
    return params


def cmd_swing(args) -> int:
    """``bplir swing``: one swing (or a comparison, or a study sample's replay)."""
    from .analysis.swing.run import run_swing, summary_with_params, write_log_csv
    from .analysis.swing.plots import animate_swing, replay_swing_html

    replay_info = None
    replaying = args.replay is not None or args.sample is not None
    params = None if replaying else _swing_params(args)   # bad options: nothing written
    if replaying:
        _replay_check(args)
    out_dir = _out_dir(args.out)
    if replaying:
        res, replay_info = _replay(args)
    if replay_info is None and args.compare:
        from .analysis.swing.compare import comparison_table, compare_presets, plot_comparison

        rows = compare_presets(params)
        fig = _save(args, plot_comparison(rows), out_dir / "comparison.png")
        table = comparison_table(rows)
        write_text_atomic(out_dir / "comparison.md", table + "\n")
        data = [{k: v for k, v in r.items() if k != "_result"} for r in rows]
        _write_json(out_dir / "comparison.json", data)
        _emit({"comparison": data, "figure": str(fig)}, args.json, [table, f"figure: {fig}"])
        return 0
    if replay_info is None:
        res = run_swing(params)
    files = {"figure": str(_save(args, res.plot(), out_dir / "swing.png")),
             "log_csv": str(write_log_csv(res, out_dir / "swing_log.csv"))}
    if not args.no_animation:
        files["animation"] = str(animate_swing(res, out_dir / "swing.gif"))
    if args.html:
        files["replay_html"] = str(replay_swing_html(res, out_dir / "swing.html"))
    extra = {"files": files} | ({"replay": replay_info} if replay_info else {})
    summary = summary_with_params(res) | extra
    _write_json(out_dir / "summary.json", summary)
    s = res.summary
    replay_line = ([f"replay of sample {replay_info['sample']} of {replay_info['study']}: "
                    + {True: "matches the recorded result exactly",
                       False: "DIFFERS from the recorded result",
                       None: "no recorded result to compare"}[replay_info["matches_recorded"]]]
                   if replay_info else [])
    _emit(res.summary | extra, args.json, replay_line + [
        f"{s['outcome']}: t = {s['swing_time_s']:.3f} s, capture speed "
        f"{s['capture_speed_mps']:.3f} m/s (limit {s['thresholds']['capture_speed_mps']}), "
        f"distance {s['capture_distance_m']:.4f} m",
        f"peak torque {s['peak_torque_Nm']:.2f} N m, peak motor power "
        f"{s['peak_motor_power_W']:.1f} W (rating {s['motor_power_rating_W']:.0f} W), "
        f"max estimation error {s['max_estimation_error_rad']:.4f} rad, seed {s['seed']}",
        f"motor: peak winding voltage {s['peak_voltage_V']:.1f} V of the driver's "
        f"{s['max_voltage_V']:.1f} V ({s['supply_voltage_V']:g} V supply), "
        f"{s['on_envelope_s']:.3f} s on the envelope, {s['electrical_energy_J']:.1f} J drawn",
        f"files in {out_dir}: " + ", ".join(Path(f).name for f in files.values())])
    return 0


def _study_of(study_dir):
    """The study saved in a study directory (``StudyError`` when there is none)."""
    from .analysis.montecarlo import STUDY_FILE, StudyError, load_study

    path = Path(study_dir) / STUDY_FILE
    if not path.exists():
        raise StudyError(f"{study_dir} is not a study directory (no {STUDY_FILE})")
    return load_study(path)


def _same(a, b) -> bool:
    """Recorded and re-run values agree (NaN equals NaN)."""
    if isinstance(a, float) and isinstance(b, float) and math.isnan(a) and math.isnan(b):
        return True
    return a == b


def _replay_check(args):
    """Refuse a replay's options before anything is written."""
    if args.replay is None or args.sample is None:
        raise InputError("--replay STUDY_DIR and --sample K go together")
    study = _study_of(args.replay)
    plugins = {kind: getattr(study.params, kind).plugin for kind in ("controller", "estimator")}
    clash = [f"--{n.replace('_', '-')}" for n in ("preset", "config", "incline", "controller",
                                                   "estimator", "seed")
             if getattr(args, n, None) is not None and getattr(args, n) != plugins.get(n)]
    clash += ["--true-state"] * args.true_state + ["--compare"] * args.compare
    if clash:
        raise InputError(f"--replay takes every parameter from the study; drop {clash[0]}")
    for kind, spec in plugins.items():   # code named by a file runs only when the user names it
        if spec and getattr(args, kind, None) != spec:
            raise InputError(f"study {args.replay} runs the plug-in {kind} {spec}; name it to "
                             f"run it: --{kind} {spec}")
    if study.line is not None:
        raise InputError(f"{args.replay} is a traversal study; replay it with bplir traverse "
                         "--replay")


def _replay(args):
    """Re-run one sample of a Monte Carlo study (``--replay DIR --sample K``)."""
    from .analysis.montecarlo import RESULT_FIELDS, replay

    res, row = replay(args.replay, args.sample)
    matches = None
    if row is not None:
        matches = row["error"] == "" and all(_same(row[k], res.summary[k]) for k in RESULT_FIELDS)
    return res, {"study": str(args.replay), "sample": args.sample, "matches_recorded": matches}


# ------------------------------------------------------------------ montecarlo
def _check_plugin(params) -> None:
    """Build a plugged-in controller and estimator once, so a broken one
    fails here with its one-line error instead of in every sample."""
    from .diagrams.plugin import make_plugin

    for kind in ("controller", "estimator"):
        if getattr(params, kind).plugin:
            make_plugin(params, kind)


def _study(args):
    import dataclasses as dc

    from .analysis.montecarlo import Study, load_study

    if args.study:
        study = load_study(args.study)
        if args.preset or args.config:
            raise InputError("--study holds the parameters; drop --preset/--config")
        study = dc.replace(study, params=_with_settings(_with_hardware(study.params, args), args))
    else:
        study = Study(params=_load_params(args))
    changes = {}
    if args.samples is not None:
        changes["samples"] = args.samples
    if args.seed is not None:
        changes["seed"] = args.seed
    if changes:
        study = dc.replace(study, **changes)
    if args.incline is not None:
        p = study.params
        study = study.with_(params=p.with_(scenario=dc.replace(p.scenario,
                                                               incline_deg=args.incline)))
    if args.controller:
        study = study.with_(params=study.params.with_controller(args.controller))
    if args.estimator:
        study = study.with_(params=study.params.with_estimator(args.estimator))
    study = study.with_(params=_with_path_mode(study.params, getattr(args, "path_mode", None),
                                               getattr(args, "landing_law", None)))
    if args.true_state:
        if args.estimator:
            raise InputError("--true-state and --estimator exclude each other: the true state "
                             "replaces the estimator")
        p = study.params
        study = study.with_(params=p.with_(scenario=dc.replace(p.scenario, use_estimator=False)))
    if args.traverse:
        from .analysis.traverse.line import load_line
        from .analysis.traverse.route import plan_route

        if args.incline is not None:
            raise InputError("--traverse takes the incline from the line file; drop --incline")
        line = load_line(args.traverse, max_incline_deg=study.params.traverse.max_incline_deg)
        plan_route(line, study.params)   # crossable on paper
        study = study.with_(line=line.data)
    from .diagrams import swing_geometry

    swing_geometry(study.params)  # the nominal scenario must be possible
    _check_plugin(study.params)
    if args.workers is not None:
        _in_range("--workers", args.workers, 1, 256)
    _in_range("--samples", study.samples, 1, 1_000_000)
    return study


def cmd_montecarlo(args) -> int:
    """``bplir montecarlo``: run or resume a Monte Carlo study."""
    from .analysis.montecarlo import RESULTS_FILE, StudyResult, run_study

    study = _study(args)
    out = _out_dir(args.out)
    summary = run_study(study, out, workers=args.workers or 0, dask=args.dask,
                        scheduler=args.scheduler, progress=_progress(args))
    figs = ([str(_save(args, fig, out / name))
             for name, fig in StudyResult.load(out).figures().items()]
            if not args.no_plots else [])
    summary["files"] = {"results": str(out / RESULTS_FILE), "summary": str(out / "summary.json"),
                        "figures": figs}
    _write_json(out / "summary.json", summary)
    lo, hi = summary["success_rate_ci95"]
    pc = summary["percentiles"].get("capture_speed_mps", {})
    what = "traversals passed" if summary.get("traverse") else "swings captured"
    _emit(summary, args.json, [
        f"{summary['successes']}/{summary['samples'] - len(summary['failed_samples'])} {what}"
        f": success rate {summary['success_rate']:.3f} (95 % Wilson interval "
        f"{lo:.3f}..{hi:.3f}), root seed {summary['seed']}",
        "outcomes: " + ", ".join(f"{k} {v}" for k, v in sorted(summary["outcomes"].items())),
        (f"capture speed p50 {pc['p50']:.3f}, p95 {pc['p95']:.3f}, max {pc['max']:.3f} m/s"
         if pc else "no capture speeds"),
        f"failed samples (errors): {len(summary['failed_samples'])}; "
        f"computed now {summary['run']['computed_now']}, resumed {summary['run']['resumed_from']}",
        f"results in {out}"])
    return 0


# ------------------------------------------------------------------ benchmark
def cmd_benchmark(args) -> int:
    """``bplir benchmark``: score controller presets by category."""
    from .analysis.montecarlo.benchmark import (benchmark_table, leaderboard, leaderboard_table,
                                                plot_benchmark, run_benchmark)

    from .params import CONTROLLER_PRESETS, _is_plugin

    params = _load_params(args)
    if args.estimator:
        params = params.with_estimator(args.estimator)
    presets = [c.strip() for c in args.controllers.split(",") if c.strip()]
    if not presets or any(c not in CONTROLLER_PRESETS and not _is_plugin(c) for c in presets):
        bad = next((c for c in presets if c not in CONTROLLER_PRESETS), args.controllers)
        raise InputError(f"--controllers: '{bad}' is not a controller; allowed a "
                         "comma-separated list of " + ", ".join(CONTROLLER_PRESETS)
                         + " and module:factory plugins")
    for c in presets:
        _check_plugin(params.with_controller(c))
    if args.workers is not None:
        _in_range("--workers", args.workers, 1, 256)
    _in_range("--seed", args.seed, 0, 2 ** 32 - 1)
    out = _out_dir(args.out)
    base = None
    if args.realistic:  # checked before any work
        from .analysis.montecarlo import load_study

        _in_range("--realistic-samples", args.realistic_samples, 1, 1_000_000)
        base = load_study(args.realistic).with_(samples=args.realistic_samples, seed=args.seed)
        if args.estimator:
            base = base.with_(params=base.params.with_estimator(args.estimator))
        _realistic_studies(args, base, presets, out, run=False)  # resumable or refused now
    result = run_benchmark(params, presets, quick=args.quick, workers=args.workers or 0,
                           seed=args.seed, progress=_progress(args),
                           out=out)
    realistic = _realistic_studies(args, base, presets, out, run=True) \
        if base is not None else None
    fig = _save(args, plot_benchmark(result), out / "benchmark.png")
    table = benchmark_table(result)
    write_text_atomic(out / "benchmark.md", table + "\n")
    board = leaderboard(result, realistic)
    board_md = leaderboard_table(board)
    write_text_atomic(out / "leaderboard.md", board_md + "\n")
    _write_json(out / "leaderboard.json", board)
    result["leaderboard"] = board
    result["files"] = {"figure": str(fig), "table": str(out / "benchmark.md"),
                       "cases": str(out / "benchmark_cases.csv"),
                       "leaderboard": str(out / "leaderboard.md")}
    _write_json(out / "benchmark.json", result)
    _emit(result, args.json, [table, "", board_md, f"figure: {fig}"])
    return 0


def _realistic_studies(args, base, controllers, out, run: bool) -> dict:
    """The study ``base`` (``--realistic``, with the benchmark's ``--seed`` as
    its root seed) run for each controller into ``out/realistic/<controller>``:
    controller -> summary.  ``run=False`` only checks that every directory
    is new or holds the same study (before the benchmark's work)."""
    import re

    from .analysis.montecarlo import run_study
    from .analysis.montecarlo.runner import check_out

    summaries = {}
    for c in controllers:
        study = base.with_(params=base.params.with_controller(c))
        where = out / "realistic" / re.sub(r"[^A-Za-z0-9_.-]+", "_", c)
        if not run:
            check_out(study, where)
            continue
        summaries[c] = run_study(study, where, workers=args.workers or 0,
                                 progress=_progress(args))
    return summaries


# ------------------------------------------------------------------ plan
def cmd_plan(args) -> int:
    """``bplir plan``: plan a swing by trajectory optimisation."""
    import dataclasses as dc

    import numpy as np

    from .analysis.swing.plan import plan_swing, plot_plan

    params = _load_params(args)
    if args.incline is not None:
        params = params.with_(scenario=dc.replace(params.scenario, incline_deg=args.incline))
    out = _out_dir(args.out)
    # plan_swing validates the scenario, the power limit and the knots
    plan = plan_swing(params, power_limit=args.power, knots=args.knots, progress=_progress(args))
    figure = _save(args, plot_plan(plan, params), out / "plan.png")
    summary = plan.summary() | {"figure": str(figure)}
    _write_json(out / "plan.json", summary)
    with atomic_path(out / "plan.csv") as tmp:
        np.savetxt(tmp, np.c_[plan.times, plan.states, plan.torque],
                   delimiter=",", header="t,q1,q2,q1d,q2d,tau", comments="")
    verdict = "feasible" if plan.feasible else "NOT feasible"
    _emit(summary, args.json, [
        f"planned swing on a {plan.incline_deg:g} deg line: {verdict} "
        f"(solver {plan.solver}, optimal: {plan.solved})",
        f"  duration {plan.duration:.3f} s, peak torque {plan.peak_torque:.1f} N m, "
        f"peak power {plan.peak_power:.0f} W (limit {plan.power_limit:g} W)",
        f"  motor work {plan.energy_in:.1f} J, friction loss {plan.dissipated:.1f} J, "
        f"link 1 reverses {plan.link1_reversals}x",
        f"  wrote {out}/plan.png, plan.csv, plan.json"])
    return 0 if plan.feasible else 1


# ------------------------------------------------------------------ calibrate
def cmd_calibrate(args) -> int:
    """``bplir calibrate``: fit the model to a logged run."""
    from .analysis.identification.calibration import (calibrate, identify_deadband, identify_plant_family,
                                       read_calibration_csv,
                                       write_calibrated_toml)

    fit = tuple(n.strip() for n in args.fit.split(",") if n.strip())
    twice = sorted({n for n in fit if fit.count(n) > 1})
    if twice:
        raise InputError(f"--fit names {', '.join(twice)} more than once; name each "
                         "parameter once")
    params = _load_params(args)
    log = read_calibration_csv(args.log, params.motor.torque_per_amp)
    out_dir = _out_dir(args.out)   # after the log's checks: a refusal writes nothing
    res = calibrate(params, log, fit, progress=_progress(args))
    summary = res.summary() | {
        "toml": str(write_calibrated_toml(res, out_dir / "calibrated.toml")),
        "plot": str(_save(args, res.plot(), out_dir / "calibration.png"))}
    if args.deadband:
        summary["deadband"] = identify_deadband(res.params)
    if args.family:
        fam = identify_plant_family(res.params)
        summary["plant_family"] = {"ranges": fam.ranges, "fits": fam.fits}
    _write_json(out_dir / "calibration.json", summary)
    lines = [f"RMSE {res.rmse_before:.4f} -> {res.rmse_after:.4f} rad after {res.nfev} simulations"]
    lines += [f"  {n} = {v:.6g} +/- {se:.2g}" for n, v, se in
              zip(res.names, res.values, res.std_errors)]
    lines.append(f"calibrated parameters: {summary['toml']} (use with --config)")
    _emit(summary, args.json, lines)
    return 0


# ------------------------------------------------------------------ traverse
def cmd_traverse(args) -> int:
    """``bplir traverse``: cross a stretch of line with obstacles."""
    from .analysis.traverse.line import load_line
    from .analysis.traverse.plots import plot_timeline, traverse_replay_html
    from .analysis.traverse.run import (manoeuvre_table, run_traverse, totals_lines,
                                        write_rows_csv)

    replay_info = None
    if args.replay is not None or args.sample is not None:
        if args.replay is None or args.sample is None:
            raise InputError("--replay STUDY_DIR and --sample K go together")
        clash = [f"--{n}" for n in ("preset", "config", "seed") if getattr(args, n) is not None]
        clash += ["LINE"] if args.line is not None else []
        if clash:
            raise InputError(f"--replay takes the line and every parameter from the study; "
                             f"drop {clash[0]}")
    elif args.line is None:
        raise InputError("give a line file (LINE.toml) or --replay STUDY_DIR --sample K")
    else:
        params = _load_params(args)
        if args.seed is not None:
            _in_range("--seed", args.seed, 0, 2 ** 32 - 1)
        line = load_line(args.line, max_incline_deg=params.traverse.max_incline_deg)
    if args.replay is not None:
        study = _study_of(args.replay)
        if study.line is None:
            raise InputError(f"{args.replay} is a swing study; replay it with bplir swing --replay")
    out = _out_dir(args.out)
    if args.replay is not None:
        from .analysis.montecarlo import replay

        res, row = replay(args.replay, args.sample)
        fields = res.sample_fields()
        matches = None if row is None else row["error"] == "" and all(
            _same(row[k], fields[k]) for k in study.result_fields)
        replay_info = {"study": str(args.replay), "sample": args.sample,
                       "matches_recorded": matches}
    else:
        res = run_traverse(line, params, seed=args.seed or 0, progress=_progress(args))
    files = {"figure_line": str(_save(args, res.plot(), out / "line.png")),
             "figure_timeline": str(_save(args, plot_timeline(res), out / "timeline.png")),
             "manoeuvres_csv": str(write_rows_csv(res, out / "manoeuvres.csv"))}
    table = manoeuvre_table(res)
    write_text_atomic(out / "manoeuvres.md", table + "\n")
    files["manoeuvres_md"] = str(out / "manoeuvres.md")
    if not args.no_animation:
        files["replay_html"] = str(traverse_replay_html(res, out / "traverse.html"))
    data = res.to_dict() | {"files": files} | ({"replay": replay_info} if replay_info else {})
    _write_json(out / "traverse.json", data)
    replay_line = ([f"replay of sample {replay_info['sample']} of {replay_info['study']}: "
                    + {True: "matches the recorded result exactly",
                       False: "DIFFERS from the recorded result",
                       None: "no recorded result to compare"}[replay_info["matches_recorded"]]]
                   if replay_info else [])
    _emit(data, args.json, replay_line + [table, ""] + totals_lines(res) + [
        f"files in {out}: " + ", ".join(Path(f).name for f in files.values())])
    return 0 if res.success else 1


# ------------------------------------------------------------------ main
def build_parser() -> argparse.ArgumentParser:
    """The ``bplir`` command line: one subcommand per job."""
    parser = _Parser(prog="bplir", description="Brachiating Power Line Inspection Robot tools")
    parser.add_argument("--version", action="version", version=f"bplir {package_version()}")
    parser.add_argument("--debug", action="store_true",
                        help="show the traceback of an unexpected fault")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    def command(name, func, help, out=None):
        """A subcommand with the parameter options (and ``--out DIR``)."""
        p = sub.add_parser(name, help=help)
        p.add_argument("--preset", default=None, help="parameter preset (dissertation, lab)")
        p.add_argument("--config", default=None, help="parameter TOML file")
        p.add_argument("--set", action="append", default=[], metavar="BLOCK.FIELD=VALUE",
                       help="set one parameter (repeatable), e.g. --set plant.m2=1.6; "
                            "applied after --preset, --config and --hardware")
        p.add_argument("--hardware", default=None,
                       help="hardware added to the robot, comma-separated: line-sensor (the "
                            "jaw's line range sensor), 48v (a 48 V supply instead of 30 V)")
        p.add_argument("--json", action="store_true", help="print JSON on stdout")
        if out:
            p.add_argument("--out", default=out, help=f"output directory (default {out})")
            p.add_argument("--format", default="png", choices=FIGURE_FORMATS,
                           help="figure format (default png)")
            p.add_argument("--dpi", type=_dpi_value, default=150,
                           help="figure resolution in dots per inch, 30-1200 (default 150)")
        p.set_defaults(func=func)
        return p

    def option(p, name, kind=None, default=None, help=None, **kw):
        if kind is bool:
            return p.add_argument(name, action="store_true", help=help)
        return p.add_argument(name, type=kind, default=default, help=help, **kw)

    def shared(p, *names):
        """Options several subcommands share, by name."""
        table = {"incline": ("--incline", float, None, "line incline in degrees"),
                 "controller": ("--controller", None, None,
                                "controller preset (qft, dissertation, lab) or your own, "
                                "module:factory (a module or .py file)"),
                 "preset": ("--controller", None, None,
                            "controller preset (qft, dissertation, lab)"),
                 "estimator": ("--estimator", None, None,
                               "your own estimator instead of the EKF, module:factory "
                               "(a module or .py file)"),
                 "workers": ("--workers", int, None, "worker processes (default: all cores)"),
                 "path": ("--path-mode", None, None,
                          "how the swing is steered: auto (the default: plan for the qft "
                          "preset, adaptive for the others and plug-ins), adaptive (the "
                          "path generator), plan (plan tracking with the apex landing), "
                          "rts, lab"),
                 "landing": ("--landing-law", None, None,
                             "plan tracking's landing: aim, shoot, or auto (the default) "
                             "(shoot where link 1 carries the planned gripper to the line, "
                             "aim where the elbow lifts it)")}
        for n in names:
            option(p, *table[n])

    p = command("model", cmd_model, "model facts: T_min, Table 4.1, hanging eigenvalues, the "
                "motor's torque-speed envelope with a swing's operating points", "out/model")
    shared(p, "incline")
    option(p, "--no-swing", bool, help="draw the envelope without a swing's operating points")

    p = command("params", cmd_params, "every parameter: block, name, unit, range, default and "
                "meaning (of the preset, config, hardware and --set given)")
    p.add_argument("block", nargs="?", default=None, help="one block (plant, motor, ...)")

    p = command("freeswing", cmd_freeswing, "simulate a free swing (plant + friction)",
                "out/freeswing")
    option(p, "--q0", None, "0.8,0.0", "initial angles Q1,Q2 in rad")
    option(p, "--duration", float, 10.0, "seconds to simulate")
    option(p, "--torque", float, 0.0, "constant elbow torque (N m)")
    option(p, "--no-friction", bool, help="switch friction off")

    p = command("estimate", cmd_estimate, "run the kinematic EKF over an IMU log (CSV)")
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

    p = command("observability", cmd_observability,
                "observability of the kinematic model along a swing", "out/observability")
    option(p, "--duration", float, 4.0, "seconds to simulate")
    option(p, "--torque", float, 8.0, "elbow torque after 1 s (N m)")
    option(p, "--threshold", float, 1e-3, "relative rank threshold")

    p = command("swing", cmd_swing, "one brachiation swing (the main job)", "out/swing")
    shared(p, "incline", "controller", "estimator", "path", "landing")
    option(p, "--seed", int, None, "seed of friction draw and sensor noise")
    option(p, "--true-state", bool, help="control from the true state")
    option(p, "--no-animation", bool, help="skip the GIF")
    option(p, "--html", bool, help="also write swing.html: a Meshcat 3-D replay to open in a "
           "browser (self-contained, works offline)")
    option(p, "--compare", bool, help="run the swing with each controller preset and the true state")
    option(p, "--replay", None, None, "re-run one sample of a Monte Carlo study (with --sample)",
           metavar="STUDY_DIR")
    option(p, "--sample", int, None, "sample index to replay", metavar="K")

    p = command("montecarlo", cmd_montecarlo,
                "Monte Carlo robustness study over uncertain parameters", "out/montecarlo")
    p.add_argument("-n", "--samples", type=int, default=None, help="number of swings")
    option(p, "--seed", int, None, "root seed of the study")
    shared(p, "workers", "incline", "controller", "estimator", "path", "landing")
    option(p, "--study", None, None, "study TOML file (distributions, scenario)")
    option(p, "--true-state", bool, help="control from the true state (no estimator): what "
           "estimation costs the study")
    option(p, "--traverse", None, None, "a traversal study: each sample crosses this line "
           "(success: every obstacle passed, no driver trip, no fall)", metavar="LINE.toml")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on an existing Dask cluster")
    g.add_argument("--dask", action="store_true", help="run on a local Dask cluster")
    option(p, "--no-plots", bool, help="skip the figures")

    p = command("benchmark", cmd_benchmark, "robustness benchmark of the controller presets",
                "out/benchmark")
    option(p, "--quick", bool, help="fewer cases (about a minute)")
    option(p, "--controllers", None, "qft,dissertation,lab",
           "controllers to score: presets and module:factory plugins")
    shared(p, "workers", "estimator")
    option(p, "--seed", int, 0, "root seed of the benchmark")
    option(p, "--realistic", None, None,
           "also run this study (e.g. examples/study_realistic.toml) per controller for the "
           "leaderboard")
    option(p, "--realistic-samples", int, 100,
           "samples of that study per controller (root seed: --seed)")

    p = command("traverse", cmd_traverse, "cross a stretch of line, brachiating past every "
                "obstacle (exit 1 when the traversal fails)", "out/traverse")
    p.add_argument("line", nargs="?", default=None,
                   help="line file (TOML): length, incline or catenary, obstacles")
    option(p, "--seed", int, None, "seed of the robot's friction draw and of every swing's "
           "sensor noise and disturbances")
    option(p, "--no-animation", bool, help="skip traverse.html (the Meshcat replay)")
    option(p, "--replay", None, None, "re-run one sample of a traversal study (with --sample)",
           metavar="STUDY_DIR")
    option(p, "--sample", int, None, "sample index to replay", metavar="K")

    p = command("plan", cmd_plan,
                "plan a swing by trajectory optimisation (torque and power limits)", "out/plan")
    shared(p, "incline")
    option(p, "--power", float, None, "motor power limit in W (default: rating)")
    option(p, "--knots", int, 41, "collocation knots")

    p = command("calibrate", cmd_calibrate, "fit the plant model to a logged run (4.5)",
                "out/calibration")
    p.add_argument("log", help="CSV with t,q1,q2 and tau (N m) or i_cmd (A)")
    option(p, "--fit", None, "fv1,fv2,fc1,fc2",
           "parameters to fit (fv1,fv2,fc1,fc2,I1,I2,lc1,lc2,m1,m2)")
    option(p, "--deadband", bool, help="also identify the dead-band of the calibrated model (4.6)")
    option(p, "--family", bool,
           help="also identify the CPFL plant family of the calibrated model (4.7)")

    p = command("qft", cmd_qft, "QFT design/verification on a plant family", "out/qft")
    p.add_argument("--family", choices=("dissertation", "diagram"), default="diagram",
                   help="plant family: published or linearised from the diagram")
    shared(p, "preset")
    option(p, "--plants", int, 60, "sampled plants of the diagram family")
    option(p, "--seed", int, 1, "seed of the sampled family")
    option(p, "--design", bool, help="re-run the loop-shaping design")
    return parser


def main(argv=None) -> int:
    """Run the command line; returns the exit status (2 with a one-line ``bplir: error:`` on bad
    input)."""
    import contextlib

    parser = build_parser()
    args = parser.parse_args(argv)
    import signal

    _OUT[0] = sys.stdout
    quiet = contextlib.redirect_stdout(sys.stderr) if getattr(args, "json", False) \
        else contextlib.nullcontext()
    previous = {}
    try:
        for sig in (signal.SIGTERM, signal.SIGHUP):
            previous[sig] = signal.signal(sig, _terminate)
    except ValueError:   # not the main thread: leave the signals alone
        pass
    try:
        with quiet:
            return args.func(args)
    except (ParameterError, InputError, LogError, QftError, CalibrationError) as exc:
        sys.stderr.write(f"bplir: error: {exc}\n")
        return 2
    except OSError as exc:   # a full disk, a vanished directory: the path and the reason
        if args.debug:
            raise
        where = f" {exc.filename}" if getattr(exc, "filename", None) else ""
        sys.stderr.write(f"bplir: error: {args.command}: cannot write or read{where}: "
                         f"{exc.strerror or exc}\n")
        return 1
    except KeyboardInterrupt as exc:
        code = 128 + exc.signum if isinstance(exc, Terminated) else 130
        what = (f"terminated by {signal.Signals(exc.signum).name}"
                if isinstance(exc, Terminated) else "interrupted")
        if args.command == "montecarlo":
            sys.stderr.write(f"bplir: {what}; the finished samples are kept in {args.out} "
                             "(the same command resumes the study)\n")
        else:  # every output is written atomically: none is left half-written
            sys.stderr.write(f"bplir: {what}; no output file was left half-written\n")
        return code
    except Exception as exc:   # a fault inside: one line (the traceback with --debug)
        if args.debug:
            raise
        if "KeyboardInterrupt" in str(exc):   # Ctrl-C inside a C++ callback (SNOPT's)
            sys.stderr.write("bplir: interrupted; no output file was left half-written\n")
            return 130
        text = " ".join(str(exc).split()) or "no message"
        sys.stderr.write(f"bplir: error: {args.command} failed: {type(exc).__name__}: "
                         f"{text[:400]}\n")
        return 1
    finally:
        _OUT[0] = None
        for sig, handler in previous.items():
            signal.signal(sig, handler)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
