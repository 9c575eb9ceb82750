"""``bplir qft``: QFT design and verification on a plant family."""
from __future__ import annotations

from .common import _emit, _in_range, _load_params, _out_dir, _progress, _save, _write_json
from .options import command, option, shared


# ------------------------------------------------------------------ qft
def cmd_qft(args) -> int:
    """``bplir qft``: verify (or design) the outer loop on a plant family."""
    from ..analysis.control.qft_report import qft_report

    params = _load_params(args)
    if args.family == "diagram":
        _in_range("--plants", args.plants, 2, 10000)
        _in_range("--seed", args.seed, 0, 2 ** 32 - 1)
    out_dir = _out_dir(args.out)
    res = qft_report(params, args.controller, family=args.family, plants=args.plants,
                     seed=args.seed, design=args.design, progress=_progress(args))
    report, ver, fam_plot = res.report, res.verification, res.family
    figs = {name.split(".")[0]: _save(args, fig, out_dir / name)
            for name, fig in res.figures().items()}
    report["figures"] = {k: str(v) for k, v in figs.items()}
    _write_json(out_dir / "qft.json", report)
    lines = [f"family: {fam_plot.name}, {len(fam_plot)} plants, controller {report['controller']}"]
    for name, c in ver.checks.items():
        lines.append(f"  {name}: {'holds' if c['holds'] else 'FAILS'} (worst {c['worst']:.4g}, "
                     f"limit {c['limit']:.4g})")
    if args.family == "dissertation":
        m = report["largest_delay_published_K_keeps_stable"]
        lines.append(f"  with Td in [0.15, 0.3] s: all specs hold: "
                     f"{report['with_delay_0.15_0.3_s']['all_hold']}; largest delay K = -216 "
                     f"keeps every plant stable: {m['largest_delay_all_plants_s']:.4f} s")
    lines.append(f"figures in {out_dir}")
    _emit(report, args.json, lines)
    return 0


def add_parser(sub) -> None:
    """Declare ``bplir qft`` and its options."""
    p = command(sub, "qft", cmd_qft, "QFT design/verification on a plant family", "out/qft")
    p.add_argument("--family", choices=("dissertation", "diagram"), default="diagram",
                   help="plant family: published or linearised from the diagram")
    shared(p, "preset")
    option(p, "--plants", int, 60, "sampled plants of the diagram family")
    option(p, "--seed", int, 1, "seed of the sampled family")
    option(p, "--design", bool, help="re-run the loop-shaping design")
