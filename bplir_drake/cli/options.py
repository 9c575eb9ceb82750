"""The options every command shares, and the helpers that declare a command's options."""
from __future__ import annotations

from ..params.control import AUTO_PATH_MODE
from .common import FIGURE_FORMATS, _dpi_value


def command(sub, name, func, help, out=None):
    """A subcommand of ``sub`` with the parameter options (and ``--out DIR``)."""
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
    """An option of ``p``: a flag when ``kind`` is bool."""
    if kind is bool:
        return p.add_argument(name, action="store_true", help=help)
    return p.add_argument(name, type=kind, default=default, help=help, **kw)

def shared(p, *names):
    """Options several subcommands share, by name."""
    table = {"incline": ("--incline", float, None, "line incline in degrees"),
             "controller": ("--controller", None, None,
                            "controller preset (plan, cpfl-qft, lab) or your own, "
                            "module:factory (a module or .py file)"),
             "preset": ("--controller", None, None,
                        "controller preset (plan, cpfl-qft, lab)"),
             "estimator": ("--estimator", None, None,
                           "your own estimator instead of the EKF, module:factory "
                           "(a module or .py file)"),
             "workers": ("--workers", int, None, "worker processes (default: all cores)"),
             "path": ("--path-mode", None, None,
                      f"how the swing is steered: auto (the default: {AUTO_PATH_MODE}), "
                      "adaptive (the path generator), plan (plan tracking with its "
                      "landing), rts, lab"),
             "landing": ("--landing-law", None, None,
                         "plan tracking's landing: auto (the default: shoot where link 1 "
                         "carries the planned gripper to the line, aim where the elbow "
                         "lifts it), shoot, aim, reach, or none (the plan tracked to its "
                         "end)")}
    for n in names:
        option(p, *table[n])
        if n in ("controller", "estimator"):   # arguments of a plug-in's factory
            p.add_argument(f"--{n}-arg", action="append", default=[], metavar="KEY=VALUE",
                           help=f"keyword argument of your {n} plug-in's factory "
                                "(repeatable): a number, true/false or text")
