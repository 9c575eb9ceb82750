"""``bplir montecarlo``: a Monte Carlo robustness study."""
from __future__ import annotations

from .common import _plugin_args_need_a_plugin, InputError, _check_plugin, _emit, _in_range, _load_params, _out_dir, _progress, _save, _with_hardware, _with_path_mode, _with_settings, _write_json
from .options import command, option, shared


def _study(args):
    import dataclasses as dc

    from ..analysis.montecarlo import Study, load_study

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
    _plugin_args_need_a_plugin(args)
    if args.controller:
        study = study.with_(params=study.params.with_controller(args.controller, args.controller_arg))
    if args.estimator:
        study = study.with_(params=study.params.with_estimator(args.estimator, args.estimator_arg))
    study = study.with_(params=_with_path_mode(study.params, getattr(args, "path_mode", None),
                                               getattr(args, "landing_law", None)))
    if args.true_state:
        if args.estimator:
            raise InputError("--true-state and --estimator exclude each other: the true state "
                             "replaces the estimator")
        p = study.params
        study = study.with_(params=p.with_(scenario=dc.replace(p.scenario, use_estimator=False)))
    if args.traverse:
        from ..analysis.traverse.line import load_line
        from ..analysis.traverse.route import plan_route

        if args.incline is not None:
            raise InputError("--traverse takes the incline from the line file; drop --incline")
        line = load_line(args.traverse, max_incline_deg=study.params.traverse.max_incline_deg)
        plan_route(line, study.params)   # crossable on paper
        study = study.with_(line=line.data)
    if args.knocks is not None:
        from ..params.knocks import parse_knocks

        if not args.traverse and study.line is None:
            raise InputError("--knocks knocks traversals; allowed only with --traverse LINE.toml "
                             "(or a study with a [line])")
        study = study.with_(knocks=parse_knocks(args.knocks).as_dict())
    from ..diagrams import swing_geometry

    swing_geometry(study.params)  # the nominal scenario must be possible
    _check_plugin(study.params)
    if args.workers is not None:
        _in_range("--workers", args.workers, 1, 256)
    _in_range("--samples", study.samples, 1, 1_000_000)
    return study


def cmd_montecarlo(args) -> int:
    """``bplir montecarlo``: run or resume a Monte Carlo study."""
    from ..analysis.montecarlo import RESULTS_FILE, StudyResult, run_study

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
    kd = summary.get("knockdown")
    knock_lines = [] if kd is None else [
        f"knocked {kd['knocks']['rate']:g} a minute at severity {kd['knocks']['severity']:g}: "
        f"mean uptime {kd['mean_uptime']:.3f}; no fall in {kd['no_fall']}/{kd['runs']} "
        f"(95 % Wilson interval {kd['no_fall_ci95'][0]:.3f}..{kd['no_fall_ci95'][1]:.3f}); "
        f"falls the interlock caused: {kd['interlock_falls']}; {kd['knocks_met']} knocks"]
    _emit(summary, args.json, knock_lines + [
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


def add_parser(sub) -> None:
    """Declare ``bplir montecarlo`` and its options."""
    p = command(sub, "montecarlo", cmd_montecarlo,
                "Monte Carlo robustness study over uncertain parameters", "out/montecarlo")
    p.add_argument("-n", "--samples", type=int, default=None, help="number of swings")
    option(p, "--seed", int, None, "root seed of the study")
    shared(p, "workers", "incline", "controller", "estimator", "path", "landing")
    option(p, "--study", None, None, "study TOML file (distributions, scenario)")
    option(p, "--true-state", bool, help="control from the true state (no estimator): what "
           "estimation costs the study")
    option(p, "--traverse", None, None, "a traversal study: each sample crosses this line "
           "(success: every obstacle passed, no driver trip, no fall)", metavar="LINE.toml")
    option(p, "--knocks", None, None, "with --traverse: knock every traversal RATE times a "
           "minute at SEVERITY (default 1: a knock that alone would swing the free link 30 deg "
           "from rest), on JOINTS (either, elbow, hold, both; default either); scored by uptime "
           "and falls", metavar="RATE[:SEVERITY[:JOINTS]]")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="run on an existing Dask cluster")
    g.add_argument("--dask", action="store_true", help="run on a local Dask cluster")
    option(p, "--no-plots", bool, help="skip the figures")
