"""Draw docs/figures/knockdown.png, the knockdown curves of the stored
knocked traversal studies (``kind = "knockdown"`` in results/manifest.toml),
one line per robot and line (a maintainer's tool, after their studies ran).

    python scripts/knockdown_figure.py
"""
from __future__ import annotations

import json
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))   # the package of this checkout


def main() -> int:
    from bplir_drake.analysis.montecarlo.knockdown import knockdown_curve, plot_knockdown
    from bplir_drake.params.knocks import STANDARD_SEVERITY
    from bplir_drake.plotting import save_figure

    items = tomllib.loads((ROOT / "results" / "manifest.toml").read_text())["output"]
    by_robot: dict[str, list[dict]] = {}
    for item in items:
        if item.get("kind") == "knockdown":
            summary = json.loads((ROOT / "results" / item["path"] / "summary.json").read_text())
            by_robot.setdefault(item["curve"], []).append(summary)
    curves = {label: knockdown_curve(s) for label, s in by_robot.items()}
    out = save_figure(plot_knockdown(curves, standard=STANDARD_SEVERITY),
                      ROOT / "docs" / "figures" / "knockdown.png", dpi=150)
    print(f"wrote {Path(out).relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
