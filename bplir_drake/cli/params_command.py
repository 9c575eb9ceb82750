"""``bplir params``: every parameter with its unit, range, default and meaning."""
from __future__ import annotations

from .common import _emit, _load_params
from .options import command


# ------------------------------------------------------------------ params
def cmd_params(args) -> int:
    """``bplir params``: the parameter reference with the values in force."""
    from ..params import parameter_reference

    params = _load_params(args)
    rows = parameter_reference([args.block] if args.block else None)
    for r in rows:
        r["default"] = getattr(getattr(params, r["block"]), r["name"])
    if args.json:
        _emit({"parameters": [dict(r, value=r.pop("default")) for r in rows]}, True, [])
        return 0
    width = max(len(f"{r['block']}.{r['name']}") for r in rows)
    def shown(v):
        return f"{v:.6g}" if isinstance(v, float) else str(v)

    lines = [f"{r['block'] + '.' + r['name']:<{width}}  {shown(r['default']):<12} "
             f"{r['unit']:<10} {r['range']:<16} {r['doc']}" for r in rows]
    _emit(None, False, lines)
    return 0


def add_parser(sub) -> None:
    """Declare ``bplir params`` and its options."""
    p = command(sub, "params", cmd_params, "every parameter: block, name, unit, range, default and "
                "meaning (of the preset, config, hardware and --set given)")
    p.add_argument("block", nargs="?", default=None, help="one block (plant, motor, ...)")
