"""The ``bplir`` command line.

Every sub-command accepts ``--preset NAME`` and ``--config FILE.toml``.  Bad
input (parameters, files, scenarios) prints one line ``bplir: error: ...``
to stderr and exits with status 2.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

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
        params = load_toml(args.config)
        if args.preset and args.preset != params.preset_name:
            from .params import from_dict, to_dict

            data = to_dict(params)
            data["preset"] = args.preset
            params = from_dict(data)
        return params
    return preset(args.preset or "dissertation")


def _emit(obj, as_json: bool, text_lines) -> None:
    if as_json:
        print(json.dumps(obj, indent=2, default=_jsonable))
    else:
        for line in text_lines:
            print(line)


def _jsonable(o):
    import numpy as np

    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, complex):
        return [o.real, o.imag]
    raise TypeError(f"not JSON serialisable: {type(o)}")


# ------------------------------------------------------------------ model
def cmd_model(args) -> int:
    from .analysis.friction_table import PUBLISHED_TABLE_4_1, friction_table, published_setup
    from .analysis.linearization import hanging_linearization
    from .analysis.pendulum import pendulum_periods
    from .params import to_dict

    params = _load_params(args)
    per = pendulum_periods(params.plant)
    fr = params.friction
    t_elbow = friction_table(fr.fc2, fr.b, 40.0)
    t_pub = published_setup(fr.b)
    lin = hanging_linearization(params)
    wn, zeta = lin.modes()
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
    ]
    _emit(out, args.json, lines)
    return 0


# ------------------------------------------------------------------ freeswing
def cmd_freeswing(args) -> int:
    from .analysis.freeswing import simulate_free_swing
    from .analysis.plots import plot_free_swing

    params = _load_params(args)
    q0 = _floats(args.q0, 2, "--q0")
    if not (args.duration > 0 and math.isfinite(args.duration) and args.duration <= 600):
        raise InputError(f"--duration = {args.duration:g} s is out of range; allowed (0, 600] s")
    res = simulate_free_swing(params, q0, args.duration, elbow_torque=args.torque,
                              friction=not args.no_friction, log_period=0.005)
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    plot = plot_free_swing(res, out_dir / "freeswing.png")
    summary = res.summary() | {"plot": str(plot), "friction": not args.no_friction,
                               "elbow_torque_Nm": args.torque}
    (out_dir / "freeswing.json").write_text(json.dumps(summary, indent=2))
    _emit(summary, args.json, [
        f"energy at start {res.energy_start:.4f} J, at end {res.energy_end:.4f} J "
        f"(change {res.energy_end - res.energy_start:+.4f} J)", f"plot: {plot}"])
    return 0


# ------------------------------------------------------------------ main
def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="bplir", description="Brachiating Power Line Inspection Robot tools")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)

    def common(p):
        p.add_argument("--preset", default=None, help="parameter preset (dissertation, lab)")
        p.add_argument("--config", default=None, help="parameter TOML file")
        p.add_argument("--json", action="store_true", help="print JSON on stdout")

    p = sub.add_parser("model", help="model facts: T_min, Table 4.1, hanging eigenvalues")
    common(p)
    p.set_defaults(func=cmd_model)

    p = sub.add_parser("freeswing", help="simulate a free swing (plant + friction)")
    common(p)
    p.add_argument("--q0", default="0.8,0.0", help="initial angles Q1,Q2 in rad")
    p.add_argument("--duration", type=float, default=10.0, help="seconds to simulate")
    p.add_argument("--torque", type=float, default=0.0, help="constant elbow torque (N m)")
    p.add_argument("--no-friction", action="store_true", help="switch friction off")
    p.add_argument("--out", default="out/freeswing", help="output directory")
    p.set_defaults(func=cmd_freeswing)
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (ParameterError, InputError) as exc:
        sys.stderr.write(f"bplir: error: {exc}\n")
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
