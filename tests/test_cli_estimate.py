"""`bplir estimate` and `bplir observability` from the command line; bad logs."""
import json

import numpy as np
import pytest

from bplir_drake.analysis.estimation.filter_study import simulate_estimation
from bplir_drake.cli import main
from bplir_drake.estimation import LogError, read_imu_csv, write_imu_csv


@pytest.fixture(scope="module")
def log_run(params):
    return simulate_estimation(params, duration=4.0, initial_error=(0.8, 0, 0, 0), seed=2)


@pytest.fixture()
def log_csv(tmp_path, log_run):
    r = log_run
    return write_imu_csv(r.t, r.imu, tmp_path / "log.csv",
                         extra={"theta1": r.truth[:, 0], "theta2": r.truth[:, 1]})


def test_estimate_cli_writes_csv_and_plot(tmp_path, log_csv, log_run, capsys):
    x0 = ",".join(str(v) for v in log_run.x0_estimate)
    assert main(["estimate", str(log_csv), "--x0", x0, "--out", str(tmp_path / "est.csv"),
                 "--plot", str(tmp_path / "est.png"), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["samples"] == len(log_run.t)
    est = np.genfromtxt(tmp_path / "est.csv", delimiter=",", names=True)
    assert list(est.dtype.names[:5]) == ["t", "theta1", "theta2", "omega1", "omega2"]
    np.testing.assert_allclose(est["theta1"], log_run.estimate[:, 0], atol=1e-7)
    assert (tmp_path / "est.png").stat().st_size > 30_000


def _write(tmp_path, text):
    p = tmp_path / "bad.csv"
    p.write_text(text)
    return p


def _good_rows(n=50, dt=0.01):
    return "".join(f"{k * dt:.3f},0,0,0,9.81,0,9.81\n" for k in range(n))


HEADER = "t,gyro1,gyro2,acc1_x,acc1_y,acc2_x,acc2_y\n"


@pytest.mark.parametrize("text, words", [
    ("t,gyro1,gyro2,acc1_x,acc1_y\n0,0,0,0,9.81\n0.01,0,0,0,9.81\n", "lacks column(s) acc2_x, acc2_y"),
    (HEADER + "0,0,0,0,9.81,0,9.81\n0.01,0,abc,0,9.81,0,9.81\n", "line 3 column gyro2: 'abc' is not a number"),
    (HEADER + "0,0,0,0,9.81,0,9.81\n0.01,0,0,0,9.81,0,9.81\n0.01,0,0,0,9.81,0,9.81\n", "time is not increasing at row 3"),
    (HEADER + _good_rows(50, 0.05), "sampling period 0.05 s differs from the configured 0.01 s"),
    (HEADER + _good_rows(5) + "0.05,nan,0,0,9.81,0,9.81\n0.06,nan,0,0,9.81,0,9.81\n" + "0.07,0,0,0,9.81,0,9.81\n", "rows 6 and 7 both have missing"),
    (HEADER + "0,0,0,0,9.81,0,9.81\n", "need at least 2"),
    ("", "is empty"),
])
def test_bad_logs(tmp_path, text, words, capsys):
    p = _write(tmp_path, text)
    with pytest.raises(LogError) as err:
        from bplir_drake.estimation import check_log
        from bplir_drake.params import EstimatorParams

        log = read_imu_csv(p)
        check_log(log.t, log.samples, EstimatorParams().period)
    assert words in str(err.value)
    assert main(["estimate", str(p)]) == 2
    e = capsys.readouterr().err
    assert e.startswith("bplir: error:") and e.count("\n") == 1 and words in e


def test_isolated_nan_row_is_documented_skip(tmp_path, capsys):
    text = HEADER + _good_rows(5) + "0.05,,0,0,9.81,0,9.81\n" + "".join(
        f"{0.06 + k * 0.01:.3f},0,0,0,9.81,0,9.81\n" for k in range(5))
    p = _write(tmp_path, text)
    assert main(["estimate", str(p), "--json"]) == 0
    assert json.loads(capsys.readouterr().out)["skipped_updates"] == 1


def test_observability_cli(tmp_path, capsys):
    assert main(["observability", "--duration", "2.5", "--out", str(tmp_path), "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["min_rank_full"] == 4
    assert out["min_rank_gyro_only"] == 3
    assert out["full_rank_fraction_full"] == 1.0
    assert (tmp_path / "observability.png").stat().st_size > 30_000


def test_estimate_smooth_and_report(tmp_path, log_csv, log_run, capsys):
    """--smooth writes the RTS smoother beside the causal estimate; --report
    draws angles, rates, biases with +/-2 sigma and the NIS check."""
    x0 = ",".join(str(v) for v in log_run.x0_estimate)
    assert main(["estimate", str(log_csv), "--x0", x0, "--smooth", "--out",
                 str(tmp_path / "est.csv"), "--report", str(tmp_path / "report.png"),
                 "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert set(out["nis"]) == {"mean_nis", "band", "updates", "consistent"}
    est = np.genfromtxt(tmp_path / "est.csv", delimiter=",", names=True)
    np.testing.assert_allclose(est["theta1"], log_run.estimate[:, 0], atol=1e-7)  # unchanged
    truth = log_run.truth[:, :2]
    causal = np.column_stack([est["theta1"], est["theta2"]])
    smooth = np.column_stack([est["smooth_theta1"], est["smooth_theta2"]])
    # from a 0.8 rad start error the smoother, which sees the whole log, is
    # far closer to the truth over the first second than the causal filter
    first = log_run.t < 1.0
    assert np.abs(smooth - truth)[first].max() < 0.3 * np.abs(causal - truth)[first].max()
    assert (tmp_path / "report.png").stat().st_size > 80_000
