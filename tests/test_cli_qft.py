"""`bplir qft` and the zero-dynamics portraits."""
import json
import pytest

import numpy as np
from bplir_drake.analysis.control.zero_dynamics import zero_dynamics_portrait
from bplir_drake.cli import main


@pytest.mark.slow
def test_qft_cli_diagram_family(tmp_path, capsys, strict_json):
    assert main(["qft", "--plants", "12", "--seed", "4", "--out", str(tmp_path), "--json"]) == 0
    out = strict_json(capsys.readouterr().out)   # no NaN or Infinity (hardening item 9)
    assert [strict_json(f.read_text()) for f in tmp_path.rglob("*.json")]
    assert out["verification"]["all_hold"]
    assert out["verification"]["plants"] == 13   # 55 plants: test_control.py
    for name in ("nichols", "tracking", "responses", "zero_dynamics"):
        assert (tmp_path / f"{name if name != 'tracking' else 'tracking_bode'}"
                .replace("responses", "family_responses")).with_suffix(".png").stat().st_size > 30_000


@pytest.mark.slow
def test_qft_cli_dissertation_family(tmp_path, capsys):
    assert main(["qft", "--family", "dissertation", "--controller", "dissertation", "--out",
                 str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    lo, hi = out["dc_tracking_band_without_delay"]
    assert 0.9 <= lo < hi <= 1.1
    assert out["largest_delay_published_K_keeps_stable"]["largest_delay_all_plants_s"] < 0.05
    assert not out["with_delay_0.15_0.3_s"]["all_hold"]


def test_qft_cli_bad_input(capsys):
    assert main(["qft", "--plants", "0"]) == 2
    assert "--plants = 0 is out of range; allowed [2, 10000]" in capsys.readouterr().err


def test_zero_dynamics_conservative_without_friction_and_focus_with(params):
    free = zero_dynamics_portrait(params.plant, None)
    for e in free.energy_like(params.plant):
        assert np.ptp(e) < 1e-7 * abs(e).mean()
    from bplir_drake.analysis.control.zero_dynamics import _potential

    damped = zero_dynamics_portrait(params.plant, params.friction, duration=40.0)
    v_min = _potential(0.0, 0.0, params.plant)
    for e in damped.energy_like(params.plant):
        assert np.all(np.diff(e) <= 1e-9)          # energy never increases ...
        # ... and the orbit spirals in: 11-18 % of the excess energy left after 40 s
        assert (e[-1] - v_min) / (e[0] - v_min) < 0.25
