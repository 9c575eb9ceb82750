"""``bplir model``: model facts and the motor's torque-speed envelope."""
from __future__ import annotations

from .common import _emit, _load_params, _out_dir, _save
from .options import command, option, shared


# ------------------------------------------------------------------ model
def cmd_model(args) -> int:
    """``bplir model``: minimum pendulum period, Table 4.1, hanging eigenvalues."""
    from ..analysis.model.friction_table import PUBLISHED_TABLE_4_1, friction_table, published_setup
    from dataclasses import replace

    from ..analysis.model.envelope import torque_envelope
    from ..analysis.model.linearization import friction_poles, hanging_linearization
    from ..analysis.model.pendulum import pendulum_periods
    from ..analysis.swing import run_swing
    from ..params import PlantParams, to_dict

    params = _load_params(args)
    out_dir = _out_dir(args.out)
    if args.incline is not None:
        params = params.with_(scenario=replace(params.scenario, incline_deg=args.incline))
    per = pendulum_periods(params.plant)
    fr = params.friction
    dissertation = params.plant == PlantParams()   # Table 4.1 is that robot's
    t_elbow = friction_table(fr.fc2, fr.b, 40.0)
    t_pub = published_setup(fr.b)
    lin = hanging_linearization(params)
    wn, zeta = lin.modes
    note = friction_poles(params, lin)
    swing = None if args.no_swing else run_swing(params)
    env = torque_envelope(params, swing=swing)
    out = {
        "T_min_s": per.T_min_printed,
        "T_min_note": "(6.14) as printed uses l1 + lc2: the links straight (q2 = 0), "
                      "the largest CoM radius, not the folded robot",
        "T_folded_s": per.T_folded,
        "T_compound_straight_s": per.T_straight_compound,
        "hanging_eigenvalues": [[float(z.real), float(z.imag)] for z in lin.eigenvalues],
        "hanging_modes": [{"wn_rad_s": float(w), "zeta": float(z)} for w, z in zip(wn, zeta)],
        "hanging_eigenvalues_note": note,
        "torque_per_amp_Nm_A": params.motor.torque_per_amp,
        "envelope": env.summary(),
        "files": {"envelope": str(_save(args, env.plot(), out_dir / "envelope.png"))},
        "parameters": to_dict(params),
    }
    if dissertation:
        out |= {
            "friction_rmse_candidate": t_elbow.rmse_candidate,
            "friction_rmse_viscous": t_elbow.rmse_viscous,
            "friction_rmse_setup": {"joint": "elbow", "fc_Nm": t_elbow.fc, "b_rad_s": t_elbow.b,
                                    "velocity_range_rad_s": [-t_elbow.vmax, t_elbow.vmax]},
            "friction_rmse_published": PUBLISHED_TABLE_4_1,
            "friction_rmse_published_setup": {
                "fc_Nm": t_pub.fc, "velocity_range_rad_s": [-t_pub.vmax, t_pub.vmax],
                "rmse_candidate": t_pub.rmse_candidate, "rmse_viscous": t_pub.rmse_viscous}}
    lines = [
        f"T_min (6.14 as printed, links straight) = {per.T_min_printed:.3f} s; "
        f"folded (q2 = pi) = {per.T_folded:.3f} s",
    ] + ([
        f"Table 4.1 elbow over +/-40 rad/s: candidate RMSE {t_elbow.rmse_candidate:.4f} N m, "
        f"viscous-only {t_elbow.rmse_viscous:.4f} N m",
        f"  published 0.0272 / 0.35 reproduced by fc = {t_pub.fc} N m over "
        f"+/-{t_pub.vmax} rad/s: {t_pub.rmse_candidate:.4f} / {t_pub.rmse_viscous:.4f}",
    ] if dissertation else []) + [
        "hanging eigenvalues: " + ", ".join(f"{z.real:.4g}{z.imag:+.4g}j" for z in lin.eigenvalues),
    ] + ([f"  {note}"] if note else []) + [
        (f"motor at {env.supply_voltage:g} V: no-load elbow rate {env.no_load_speed:.1f} rad/s, "
         f"full current up to {env.corner_speed():.1f} rad/s, at most {env.max_power():.0f} W"
         if params.motor.envelope else
         "motor: no voltage envelope (motor.envelope = false); the figure shows the torque limit"),
        f"envelope figure: {out['files']['envelope']}",
    ]
    _emit(out, args.json, lines)
    return 0


def add_parser(sub) -> None:
    """Declare ``bplir model`` and its options."""
    p = command(sub, "model", cmd_model, "model facts: T_min, Table 4.1 (the dissertation's "
                "robot), hanging eigenvalues, the "
                "motor's torque-speed envelope with a swing's operating points", "out/model")
    shared(p, "incline")
    option(p, "--no-swing", bool, help="draw the envelope without a swing's operating points")
