"""``bplir observability``: observability of the kinematic model along a swing."""
from __future__ import annotations

from .common import _emit, _in_range, _load_params, _out_dir, _save, _write_json
from .options import command, option


# ------------------------------------------------------------------ observability
def cmd_observability(args) -> int:
    """``bplir observability``: observability of the kinematic model along a swing."""
    from ..analysis.estimation.filter_study import simulate_estimation
    from ..analysis.estimation.observability import observability_along, plant_gyro_observability
    from ..systems.plant import initial_configuration

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


def add_parser(sub) -> None:
    """Declare ``bplir observability`` and its options."""
    p = command(sub, "observability", cmd_observability,
                "observability of the kinematic model along a swing", "out/observability")
    option(p, "--duration", float, 4.0, "seconds to simulate")
    option(p, "--torque", float, 8.0, "elbow torque after 1 s (N m)")
    option(p, "--threshold", float, 1e-3, "relative rank threshold")
