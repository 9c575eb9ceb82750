"""``bplir commission``: a robot's plans, gains and verdict from its description."""
from __future__ import annotations

from pathlib import Path

from .common import InputError, _check_plugin, _dpi, _emit, _in_range, _load_params, _out_dir, _progress
from .options import command, option, shared


def cmd_commission(args) -> int:
    """``bplir commission ROBOT.toml``: commission the robot the file describes."""
    from ..analysis.commission import commission

    if not Path(args.robot).is_file():
        raise InputError(f"robot file '{args.robot}' does not exist; name a parameter TOML "
                         "file describing the robot ([robot] file or [plant], [motor], ...)")
    if args.config:
        raise InputError(f"--config {args.config}: the robot file is the command's argument "
                         f"({args.robot}); give one")
    args.config = args.robot
    params = _load_params(args)
    inclines = args.incline or [0.0]
    for a in inclines:
        _in_range("--incline", a, -30.0, 30.0, unit="deg")
    for d in args.spacing or []:
        _in_range("--spacing", d, 0.0, 20.0, lo_open=True, unit="m")
    if args.samples is not None:
        _in_range("--samples", args.samples, 1, 100000)
    _in_range("--seed", args.seed, 0, 2 ** 32 - 1)
    if args.workers is not None:
        _in_range("--workers", args.workers, 1, 256)
    _check_plugin(params)   # a plug-in the robot file names is built before any work
    out = _out_dir(args.out)
    sized = {} if args.samples is None else {"samples": args.samples}
    result = commission(params, inclines=inclines, spacings=args.spacing, **sized,
                        seed=args.seed, out=out, workers=args.workers or 0,
                        progress=_progress(args), name=Path(args.robot).stem,
                        grippers=tuple(sorted(set(args.gripper or [1, 2]))),
                        hanging=not args.no_hanging, pumps=not args.no_pump,
                        dask=args.dask, scheduler=args.scheduler,
                        figure=(args.format, _dpi(args)))
    s = result.summary()
    lines = [f"{s['robot']}: {s['verdict'].upper()} "
             f"({s['plans']['solved']}/{s['plans']['points']} plans, "
             f"{s['plans']['from_similarity']} from similar robots; {s['wall_s']:.0f} s)"]
    for st in s["studies"]:
        by = "" if st["manoeuvre"] == "swing" else f" by {st['manoeuvre']}"
        by += "" if st["chosen"] else " (not chosen)"
        lines.append(f"  gripper {st['holding']}{by}, {st['incline_deg']:+g} deg: captured "
                     f"{st['captured']}/{st['samples']}, "
                     f"capture speed p95 {st['capture_speed_p95_mps']:.2f} m/s")
    lines += [f"  limit: {x}" for x in s["limits"]]
    lines += [f"  not shown: {x}" for x in s["unshown"]]
    if s["manoeuvre"] != params.scenario.manoeuvre:
        lines.append(f"  traversals: [scenario] manoeuvre = \"{s['manoeuvre']}\" does what "
                     "this commission chose")
    lines.append(f"  wrote {out}/report.md, commission.json, robot.toml, plans/, studies/")
    _emit(s, args.json, lines)
    return 0 if s["ready"] else 1


def add_parser(sub) -> None:
    """Declare ``bplir commission`` and its options."""
    p = command(sub, "commission", cmd_commission,
                "commission a robot from its description: plans, gains and a verdict",
                "out/commission")
    p.add_argument("robot", help="parameter TOML file of the robot ([robot] file = URDF/SDF, "
                   "or [plant]; [friction], [motor], [imu], [scenario] capture criterion)")
    option(p, "--incline", float, None, "a line incline to commission, deg (repeatable; "
           "default 0)", action="append")
    option(p, "--spacing", float, None, "a grip spacing of the plan grid, m (repeatable; "
           "default the robot's own and 5 %% of its reach either side)", action="append")
    option(p, "--gripper", int, None, "the gripper the robot holds with (repeatable; default "
           "both: 2 is the robot seen from its other gripper)", action="append", choices=(1, 2))
    option(p, "--no-hanging", bool, help="no library of swings tried again from hanging "
           "(a traversal's recovery)")
    option(p, "--no-pump", bool, help="no pumping manoeuvre from the line where a single "
           "swing leaves a limit")
    option(p, "--samples", int, None, "swings of each verification study (default 280: the "
           "fewest at which a robot capturing 99 %% shows 97 %% by its Wilson interval)")
    option(p, "--seed", int, 1, "root seed of the verification studies (default 1)")
    shared(p, "workers")
    g = p.add_mutually_exclusive_group()
    g.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="solve the plans and run the studies on an existing Dask cluster")
    g.add_argument("--dask", action="store_true", help="... on a local Dask cluster")
