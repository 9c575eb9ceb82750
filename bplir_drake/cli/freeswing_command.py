"""``bplir freeswing``: the plant and friction swinging freely."""
from __future__ import annotations

import math
from .common import _emit, _floats, _in_range, _load_params, _out_dir, _save, _write_json
from .options import command, option


# ------------------------------------------------------------------ freeswing
def cmd_freeswing(args) -> int:
    """``bplir freeswing``: simulate a free swing, write its plot and summary."""
    from ..analysis.model.freeswing import simulate_free_swing

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


def add_parser(sub) -> None:
    """Declare ``bplir freeswing`` and its options."""
    p = command(sub, "freeswing", cmd_freeswing, "simulate a free swing (plant + friction)",
                "out/freeswing")
    option(p, "--q0", None, "0.8,0.0", "initial angles Q1,Q2 in rad")
    option(p, "--duration", float, 10.0, "seconds to simulate")
    option(p, "--torque", float, 0.0, "constant elbow torque (N m)")
    option(p, "--no-friction", bool, help="switch friction off")
