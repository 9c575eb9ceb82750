"""``bplir swing``: one swing, a comparison of presets, or a study sample's replay."""
from __future__ import annotations

from pathlib import Path
from ..io import write_text_atomic
from .common import _live_view, _serve_lingering, _plugin_args_need_a_plugin, InputError, _check_plugin, _emit, _load_params, _out_dir, _same, _save, _study_of, _with_path_mode, _write_json
from .log_options import add_log_options, read_logs
from .options import command, option, shared


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
    _plugin_args_need_a_plugin(args)
    if args.controller:
        params = params.with_controller(args.controller, args.controller_arg)
    if args.estimator:
        params = params.with_estimator(args.estimator, args.estimator_arg)
    params = _with_path_mode(params, getattr(args, "path_mode", None),
                             getattr(args, "landing_law", None))
    from ..diagrams import swing_geometry

    swing_geometry(params)  # validates grip spacing / incline for this robot
    _check_plugin(params)   # a broken plug-in is refused before anything is written
    return params


def cmd_swing(args) -> int:
    """``bplir swing``: one swing (or a comparison, or a study sample's replay)."""
    from ..analysis.swing.swing_runner import run_swing, summary_with_params
    from ..analysis.swing.logs import write_log_csv
    from ..analysis.swing.swing_plots import animate_swing, replay_swing_html

    if args.wait and not args.meshcat:
        raise InputError("--wait keeps the live Meshcat view serving; allowed only with "
                         "--meshcat")
    replay_info = None
    replaying = args.replay is not None or args.sample is not None
    params = None if replaying else _swing_params(args)   # bad options: nothing written
    if replaying:
        _replay_check(args)
    against = (read_logs(args, params, [args.against], torque=False)[0]
               if args.against else None)   # checked before anything is written
    out_dir = _out_dir(args.out)
    if replaying:
        res, replay_info = _replay(args)
    if replay_info is None and args.compare:
        from ..analysis.swing.compare import comparison_table, compare_presets, plot_comparison

        rows = compare_presets(params)
        table = comparison_table(rows)
        write_text_atomic(out_dir / "comparison.md", table + "\n")
        data = [{k: v for k, v in r.items() if k != "_result"} for r in rows]
        _write_json(out_dir / "comparison.json", data)
        if args.no_plots:
            _emit({"comparison": data}, args.json, [table])
            return 0
        fig = _save(args, plot_comparison(rows), out_dir / "comparison.png")
        _emit({"comparison": data, "figure": str(fig)}, args.json, [table, f"figure: {fig}"])
        return 0
    if replay_info is None:
        res = _run_live(params, run_swing, args.wait) if args.meshcat else run_swing(params)
    files = ({} if args.no_plots else {"figure": str(_save(args, res.plot(), out_dir / "swing.png"))})
    files["log_csv"] = str(write_log_csv(res, out_dir / "swing_log.csv"))
    if not args.no_animation:
        files["animation"] = str(animate_swing(res, out_dir / "swing.gif"))
    if args.html:
        files["replay_html"] = str(replay_swing_html(res, out_dir / "swing.html"))
    against_line = []
    if against is not None:
        from ..analysis.swing.against import compare_with_log

        cmp = compare_with_log(res, against, Path(args.against).name)
        if not args.no_plots:
            files["against"] = str(_save(args, cmp.plot(), out_dir / "against.png"))
        extra_against = {"against": cmp.summary()}
        r = cmp.rmse
        against_line = [f"against {Path(args.against).name}: RMSE q1 {r[0]:.3f} rad, q2 "
                        f"{r[1]:.3f} rad over {cmp.t[-1] - cmp.t[0]:.2f} s"]
    else:
        extra_against = {}
    extra = ({"files": files} | extra_against
             | ({"replay": replay_info} if replay_info else {}))
    summary = summary_with_params(res) | extra
    _write_json(out_dir / "summary.json", summary)
    s = res.summary
    replay_line = ([f"replay of sample {replay_info['sample']} of {replay_info['study']}: "
                    + {True: "matches the recorded result exactly",
                       False: "DIFFERS from the recorded result",
                       None: "no recorded result to compare"}[replay_info["matches_recorded"]]]
                   if replay_info else [])
    _emit(res.summary | extra, args.json, replay_line + against_line + [
        _outcome_line(s),
        f"peak torque {s['peak_torque_Nm']:.2f} N m, peak motor power "
        f"{s['peak_motor_power_W']:.1f} W (rating {s['motor_power_rating_W']:.0f} W), "
        f"max estimation error {s['max_estimation_error_rad']:.4f} rad, seed {s['seed']}",
        _motor_line(res),
        f"files in {out_dir}: " + ", ".join([Path(f).name for f in files.values()]
                                            + ["summary.json"])])
    _serve_lingering()   # --meshcat --wait: until Ctrl-C
    return 0


def _run_live(params, run_swing, wait: bool = False):
    """The swing shown live in Meshcat (:func:`~.common._live_view`) with its scene."""
    from ..analysis.swing.swing_plots import swing_scene

    with _live_view(params, "swing", "real time", wait) as view:
        view.scene(swing_scene(params))
        return run_swing(params, live=view)


def _outcome_line(s: dict) -> str:
    """The outcome, its time and, for a capture, its speed and distance (a
    swing that did not capture has neither: its closest approach instead)."""
    head = f"{s['outcome']}: t = {s['swing_time_s']:.3f} s, "
    if s["outcome"] != "captured":
        return head + f"no capture: the gripper came within {s['closest_distance_m']:.4f} m"
    return head + (f"capture speed {s['capture_speed_mps']:.3f} m/s (limit "
                   f"{s['thresholds']['capture_speed_mps']}), distance "
                   f"{s['capture_distance_m']:.4f} m")


def _motor_line(res) -> str:
    """The motor's voltage figures, or, when the config models no voltage
    envelope (another robot's motor, say), that the current had none."""
    s = res.summary
    if not res.params.motor.envelope:
        return ("motor: no voltage envelope (motor.envelope = false): the driver gave any "
                "current within its limits at any speed")
    return (f"motor: peak winding voltage {s['peak_voltage_V']:.1f} V of the driver's "
            f"{s['max_voltage_V']:.1f} V ({s['supply_voltage_V']:g} V supply), "
            f"{s['on_envelope_s']:.3f} s on the envelope, {s['electrical_energy_J']:.1f} J drawn")


def _replay_check(args):
    """Refuse a replay's options before anything is written."""
    if args.replay is None or args.sample is None:
        raise InputError("--replay STUDY_DIR and --sample K go together")
    study = _study_of(args.replay)
    plugins = {kind: getattr(study.params, kind).plugin for kind in ("controller", "estimator")}
    clash = [f"--{n.replace('_', '-')}" for n in ("preset", "config", "incline", "controller",
                                                   "estimator", "seed")
             if getattr(args, n, None) is not None and getattr(args, n) != plugins.get(n)]
    clash += (["--true-state"] * args.true_state + ["--compare"] * args.compare
              + ["--against"] * bool(args.against))
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
    from ..analysis.montecarlo import RESULT_FIELDS, replay

    res, row = replay(args.replay, args.sample)
    matches = None
    if row is not None:
        matches = row["error"] == "" and all(_same(row[k], res.summary[k]) for k in RESULT_FIELDS)
    return res, {"study": str(args.replay), "sample": args.sample, "matches_recorded": matches}


def add_parser(sub) -> None:
    """Declare ``bplir swing`` and its options."""
    p = command(sub, "swing", cmd_swing, "one brachiation swing (the main job)", "out/swing")
    shared(p, "incline", "controller", "estimator", "path", "landing")
    option(p, "--seed", int, None, "seed of friction draw and sensor noise")
    option(p, "--true-state", bool, help="control from the true state")
    option(p, "--no-animation", bool, help="skip the GIF")
    option(p, "--no-plots", bool, help="skip the figures (swing.png, against.png, "
           "comparison.png); the log and the summary are written")
    option(p, "--html", bool, help="also write swing.html: a Meshcat 3-D replay to open in a "
           "browser (self-contained, works offline)")
    option(p, "--meshcat", bool, help="show the swing in Drake's Meshcat on this machine while "
           "it is simulated, at real time (the address is printed on standard error)")
    option(p, "--wait", bool, help="with --meshcat: keep Meshcat serving after the swing, its "
           "outputs written, until Ctrl-C")
    option(p, "--compare", bool, help="run the swing with each controller preset and the true state")
    option(p, "--replay", None, None, "re-run one sample of a Monte Carlo study (with --sample)",
           metavar="STUDY_DIR")
    option(p, "--sample", int, None, "sample index to replay", metavar="K")
    option(p, "--against", None, None, "a logged run of the robot (CSV) to compare the swing "
           "with: RMSE per joint over the time both cover and a figure of both; the log's "
           "clock starts with the swing (see --columns, --angles, --span)", metavar="LOG")
    add_log_options(p)
