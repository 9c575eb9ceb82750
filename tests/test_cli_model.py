"""`bplir model` and `bplir freeswing`, and the CLI's handling of bad input."""
import json
import subprocess
import sys

import pytest

from bplir_drake.cli import main


def test_model_json(tmp_path, capsys):
    assert main(["model", "--json", "--out", str(tmp_path)]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["T_min_s"] == pytest.approx(1.57, abs=0.01)
    assert out["friction_rmse_candidate"] == pytest.approx(0.0114, abs=0.0002)
    assert out["friction_rmse_viscous"] == pytest.approx(0.7681)
    assert out["friction_rmse_published_setup"]["rmse_candidate"] == pytest.approx(0.0272, rel=0.05)
    eig = out["hanging_eigenvalues"]
    assert len(eig) == 4 and all(re < 0 for re, im in eig)
    assert out["parameters"]["plant"]["m1"] == 3.2287


def test_model_draws_the_motor_envelope_with_a_swing_on_it(tmp_path, capsys):
    """``bplir model`` reports the 30 V envelope (no-load 14.4 rad/s, the
    full current up to 11.5 rad/s, 229 W at most; 23.0 rad/s and 400 W at
    48 V) and draws it with the operating points of the swing at the
    incline asked, every one of them inside it."""
    import numpy as np

    from bplir_drake.analysis.model.envelope import torque_envelope
    from bplir_drake.analysis.swing import run_swing
    from bplir_drake.params import preset

    assert main(["model", "--json", "--incline", "20", "--out", str(tmp_path)]) == 0
    env = json.loads(capsys.readouterr().out)["envelope"]
    assert env["no_load_speed_rad_s"] == pytest.approx(14.36, abs=0.01)
    assert env["corner_speed_rad_s"] == pytest.approx(11.5, abs=0.1)
    assert env["max_mechanical_power_W"] == pytest.approx(229, abs=2)
    assert 12.5 < env["swing_peak_rate_rad_s"] < env["no_load_speed_rad_s"]
    assert (tmp_path / "envelope.png").stat().st_size > 30_000
    assert main(["model", "--json", "--no-swing", "--hardware", "48v", "--format", "svg",
                 "--out", str(tmp_path / "v48")]) == 0
    env48 = json.loads(capsys.readouterr().out)["envelope"]
    assert env48["no_load_speed_rad_s"] == pytest.approx(22.98, abs=0.01)
    assert env48["max_mechanical_power_W"] == pytest.approx(400, abs=2)
    assert (tmp_path / "v48" / "envelope.svg").exists()
    p = preset()
    p = p.with_(scenario=p.scenario.__class__(**{**p.scenario.as_dict(), "incline_deg": 20.0}))
    result = torque_envelope(p, swing=run_swing(p))
    lo = np.interp(result.swing_rate, result.speeds, result.torque[:, 0])
    hi = np.interp(result.swing_rate, result.speeds, result.torque[:, 1])
    assert np.all((result.swing_torque >= lo - 1e-6) & (result.swing_torque <= hi + 1e-6))


def test_freeswing_writes_plot_and_reports_energy(tmp_path, capsys):
    assert main(["freeswing", "--q0", "0.6,0.2", "--duration", "3", "--out",
                 str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["energy_end_J"] < out["energy_start_J"]
    png = tmp_path / "freeswing.png"
    assert png.stat().st_size > 20_000


@pytest.mark.parametrize("argv, words", [
    (["model", "--preset", "nope"], "unknown preset 'nope'"),
    (["freeswing", "--q0", "1"], "--q0 = '1' must be 2"),
    (["freeswing", "--duration", "-2"], "--duration = -2 s is out of range"),
    (["model", "--config", "/nonexistent/x.toml"], "cannot read parameter file"),
    (["frobnicate"], "invalid choice"),
])
def test_bad_input_exits_2_with_one_line(argv, words, capsys):
    with pytest.raises(SystemExit) if argv[0] == "frobnicate" else _noop() as exc:
        code = main(argv)
    code = exc.value.code if argv[0] == "frobnicate" else code
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and err.startswith("bplir: error:")
    assert words in err


@pytest.mark.slow
def test_bad_toml_via_console_script(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("[plant]\nlc1 = 2.0\n")
    r = subprocess.run([sys.executable, "-m", "bplir_drake.cli", "model", "--config", str(bad)],
                       capture_output=True, text=True)
    assert r.returncode == 2
    assert r.stderr.strip() == ("bplir: error: plant.lc1 = 2 m exceeds plant.l1 = 0.9091 m; "
                                "allowed [0, l1]")


class _noop:
    def __enter__(self):
        return self

    def __exit__(self, *a):
        return False
