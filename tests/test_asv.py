"""The asv suite (``benchmarks/asv``, ``asv.conf.json``) runs from a
checkout: ``asv check`` finds its four benchmarks well formed, and ``asv run
--python=same --quick`` measures the swing's two figures (the machine
described first, as a fresh machine needs).  The 200-swing study's body is
``run_study`` on the default study, which the Monte Carlo tests run, and
the commission's is ``commission`` of the scaled example, which the
commissioning tests run; here those two are checked for form only."""
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _asv(*argv, home: Path, timeout: float = 300):
    """``asv ARGV`` in the checkout, its machine file under ``home``."""
    asv = Path(sys.executable).with_name("asv")
    return subprocess.run([str(asv), *argv], cwd=ROOT, capture_output=True, text=True,
                          timeout=timeout, env=dict(os.environ, HOME=str(home)))


@pytest.mark.slow
def test_the_asv_suite_checks_and_runs(tmp_path, monkeypatch):
    check = _asv("check", "--python=same", home=tmp_path)
    assert check.returncode == 0 and "No problems found" in check.stdout, check.stdout
    assert _asv("machine", "--yes", home=tmp_path).returncode == 0
    monkeypatch.syspath_prepend(str(ROOT / "benchmarks" / "asv"))
    import bench_package

    assert callable(bench_package.Study().time_study_200)
    assert callable(bench_package.Commission().time_commission_scaled)
    run = _asv("run", "--python=same", "--quick", "--show-stderr", "--bench", "Swing",
               home=tmp_path)
    assert run.returncode == 0, run.stdout + run.stderr
    figures = dict(re.findall(r"bench_package\.(\S+)\s+([0-9.]+)", run.stdout))
    assert set(figures) == {"Swing.track_rate_over_reference", "Swing.track_tick_us"}, run.stdout
    assert all(float(v) > 0 for v in figures.values())   # measured, not failed
