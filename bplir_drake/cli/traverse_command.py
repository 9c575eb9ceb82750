"""``bplir traverse``: cross a stretch of line with obstacles."""
from __future__ import annotations

import contextlib
from pathlib import Path

from ..io import atomic_path, write_text_atomic
from .common import InputError, _emit, _live_view, _serve_lingering, _in_range, _load_params, _out_dir, _progress, _same, _save, _study_of, _write_json
from .options import command, option


# ------------------------------------------------------------------ traverse
def _inputs(args):
    """(parameters, line, knocks, study) of ``bplir traverse``'s options
    (the study of ``--replay``, which holds the rest; else None)."""
    from ..analysis.traverse.line import load_line

    params = line = knocks = study = None
    if args.wait and not args.meshcat:
        raise InputError("--wait keeps the live Meshcat view serving; allowed only with "
                         "--meshcat")
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
    if args.knocks is not None:
        from ..params.knocks import parse_knocks

        if args.replay is not None:
            raise InputError("--replay takes the knocks from the study; drop --knocks")
        knocks = parse_knocks(args.knocks)
    if args.replay is not None:
        study = _study_of(args.replay)
        if study.line is None:
            raise InputError(f"{args.replay} is a swing study; replay it with bplir swing --replay")
    return params, line, knocks, study


def cmd_traverse(args) -> int:
    """``bplir traverse``: cross a stretch of line with obstacles."""
    from ..analysis.traverse.traverse_plots import plot_timeline, traverse_replay_html
    from ..analysis.traverse.traverse_result import MOTION_FORMAT
    from ..analysis.traverse.traversal import run_traverse
    from ..analysis.traverse.tables import manoeuvre_table, totals_lines, write_rows_csv

    params, line, knocks, study = _inputs(args)
    replay_info = None
    out = _out_dir(args.out)
    with contextlib.ExitStack() as stack:
        if args.replay is not None:
            from ..analysis.montecarlo import replay

            res, row = replay(args.replay, args.sample)
            fields = res.sample_fields()
            matches = None if row is None else row["error"] == "" and all(
                _same(row[k], fields[k]) for k in study.result_fields)
            replay_info = {"study": str(args.replay), "sample": args.sample,
                           "matches_recorded": matches}
        else:   # the motion log is written beside its file and renamed when whole
            live = (stack.enter_context(_live_view(params, "traversal", "swings at real time",
                                                   args.wait))
                    if args.meshcat else None)
            res = run_traverse(line, params, seed=args.seed or 0, progress=_progress(args),
                               motion=stack.enter_context(atomic_path(out / "motion.f64")),
                               live=live, knocks=knocks)
        files = ({} if args.no_plots else
                 {"figure_line": str(_save(args, res.plot(), out / "line.png")),
                  "figure_timeline": str(_save(args, plot_timeline(res),
                                               out / "timeline.png"))})
        files["manoeuvres_csv"] = str(write_rows_csv(res, out / "manoeuvres.csv"))
        table = manoeuvre_table(res)
        write_text_atomic(out / "manoeuvres.md", table + "\n")
        files["manoeuvres_md"] = str(out / "manoeuvres.md")
        if not args.no_animation:
            files["replay_html"] = str(traverse_replay_html(res, out / "traverse.html"))
    if res.motion.path is not None:
        res.motion.path = out / "motion.f64"
        files["motion_log"] = str(res.motion.path)
    data = res.to_dict() | {"files": files} | ({"motion_log_format": MOTION_FORMAT}
                                               if "motion_log" in files else {}) | ({"replay": replay_info} if replay_info else {})
    _write_json(out / "traverse.json", data)
    replay_line = ([f"replay of sample {replay_info['sample']} of {replay_info['study']}: "
                    + {True: "matches the recorded result exactly",
                       False: "DIFFERS from the recorded result",
                       None: "no recorded result to compare"}[replay_info["matches_recorded"]]]
                   if replay_info else [])
    _emit(data, args.json, replay_line + [table, ""] + totals_lines(res) + [
        f"files in {out}: " + ", ".join(Path(f).name for f in files.values())])
    _serve_lingering()   # --meshcat --wait: until Ctrl-C
    return 0 if res.success else 1


def add_parser(sub) -> None:
    """Declare ``bplir traverse`` and its options."""
    p = command(sub, "traverse", cmd_traverse, "cross a stretch of line, brachiating past every "
                "obstacle (exit 1 when the traversal fails)", "out/traverse")
    p.add_argument("line", nargs="?", default=None,
                   help="line file (TOML): length, incline or catenary, obstacles")
    option(p, "--seed", int, None, "seed of the robot's friction draw and of every swing's "
           "sensor noise and disturbances")
    option(p, "--no-animation", bool, help="skip traverse.html (the Meshcat replay)")
    option(p, "--no-plots", bool, help="skip the figures (line.png, timeline.png)")
    option(p, "--meshcat", bool, help="show the traversal in Drake's Meshcat on this machine "
           "while it is simulated, its swings at real time (the address on standard error)")
    option(p, "--wait", bool, help="with --meshcat: keep Meshcat serving after the traversal, "
           "its outputs written, until Ctrl-C")
    option(p, "--knocks", None, None, "knock the robot RATE times a minute at SEVERITY "
           "(default 1: a knock that alone would swing the free link 30 deg from rest), on "
           "JOINTS (either, elbow, hold, both; default either); the totals give the uptime and "
           "whether it fell", metavar="RATE[:SEVERITY[:JOINTS]]")
    option(p, "--replay", None, None, "re-run one sample of a traversal study (with --sample)",
           metavar="STUDY_DIR")
    option(p, "--sample", int, None, "sample index to replay", metavar="K")
