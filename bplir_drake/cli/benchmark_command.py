"""``bplir benchmark``: the robustness benchmark and leaderboard of controllers."""
from __future__ import annotations

from ..io import write_text_atomic
from .common import InputError, _check_plugin, _emit, _in_range, _load_params, _out_dir, _progress, _save, _write_json
from .options import command, option, shared


# ------------------------------------------------------------------ benchmark
def cmd_benchmark(args) -> int:
    """``bplir benchmark``: score controller presets by category."""
    from ..analysis.montecarlo.benchmark import (CATEGORIES, benchmark_table, leaderboard,
                                                leaderboard_table, plot_benchmark, run_benchmark)

    from ..params import CONTROLLER_PRESETS, _is_plugin, current_preset_name

    params = _load_params(args)
    if args.estimator:
        params = params.with_estimator(args.estimator, args.estimator_arg)
    presets = [current_preset_name(c.strip()) for c in args.controllers.split(",") if c.strip()]
    if not presets or any(c not in CONTROLLER_PRESETS and not _is_plugin(c) for c in presets):
        bad = next((c for c in presets if c not in CONTROLLER_PRESETS), args.controllers)
        raise InputError(f"--controllers: '{bad}' is not a controller; allowed a "
                         "comma-separated list of " + ", ".join(CONTROLLER_PRESETS)
                         + " and module:factory plugins")
    if args.controller_arg and not any(_is_plugin(c) and c not in CONTROLLER_PRESETS
                                       for c in presets):
        raise InputError("--controller-arg needs a plug-in among --controllers "
                         "(module:factory or a registered name)")
    for c in presets:
        _check_plugin(params.with_controller(c, args.controller_arg))
    if args.workers is not None:
        _in_range("--workers", args.workers, 1, 256)
    _in_range("--seed", args.seed, 0, 2 ** 32 - 1)
    out = _out_dir(args.out)
    base = None
    if args.realistic:  # checked before any work
        from ..analysis.montecarlo import load_study

        _in_range("--realistic-samples", args.realistic_samples, 1, 1_000_000)
        base = load_study(args.realistic).with_(samples=args.realistic_samples, seed=args.seed)
        if args.estimator:
            base = base.with_(params=base.params.with_estimator(args.estimator, args.estimator_arg))
        _realistic_studies(args, base, presets, out, run=False)  # resumable or refused now
    result = run_benchmark(params, presets, quick=args.quick, workers=args.workers or 0,
                           seed=args.seed, progress=_progress(args), out=out,
                           controller_args=args.controller_arg,
                           categories=tuple(args.category) or CATEGORIES)
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

    from ..analysis.montecarlo import run_study
    from ..analysis.montecarlo.runner import check_out

    summaries = {}
    for c in controllers:
        study = base.with_(params=base.params.with_controller(c, args.controller_arg))
        where = out / "realistic" / re.sub(r"[^A-Za-z0-9_.-]+", "_", c)
        if not run:
            check_out(study, where)
            continue
        summaries[c] = run_study(study, where, workers=args.workers or 0,
                                 progress=_progress(args))
    return summaries


def add_parser(sub) -> None:
    """Declare ``bplir benchmark`` and its options."""
    p = command(sub, "benchmark", cmd_benchmark, "robustness benchmark of the controller presets",
                "out/benchmark")
    option(p, "--quick", bool, help="fewer cases (about a minute)")
    option(p, "--controllers", None, "plan,cpfl-qft,lab",
           "controllers to score: presets and module:factory plugins")
    p.add_argument("--controller-arg", action="append", default=[], metavar="KEY=VALUE",
                   help="keyword argument of the factories of the plug-ins among "
                        "--controllers (repeatable): a number, true/false or text")
    p.add_argument("--category", action="append", default=[], metavar="NAME",
                   help="score only this category (repeatable; default every one): model "
                        "parameters, sensor noise, torque noise, delay, gusts, incline, link-2 "
                        "parameters, IMU bias and misalignment, grip spacing, knockdown")
    shared(p, "workers", "estimator")
    option(p, "--seed", int, 0, "root seed of the benchmark")
    option(p, "--realistic", None, None,
           "also run this study (e.g. examples/study_realistic.toml) per controller for the "
           "leaderboard")
    option(p, "--realistic-samples", int, 100,
           "samples of that study per controller (root seed: --seed)")
