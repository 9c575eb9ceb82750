"""docs/python.md runs as written: its code blocks, in order, in one
namespace, in a temporary directory."""
import re
from pathlib import Path

import pytest

DOC = Path(__file__).resolve().parents[1] / "docs" / "python.md"


def test_the_python_guide_runs(tmp_path, monkeypatch, capsys):
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(), re.S)
    assert len(blocks) >= 7
    (tmp_path / "examples").mkdir()  # the guide runs from the project's root
    for example in ("my_estimator.py",):
        (tmp_path / "examples" / example).write_text(
            (DOC.parents[1] / "examples" / example).read_text())
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__main__"}
    for i, code in enumerate(blocks):
        exec(compile(code, f"{DOC.name} block {i + 1}", "exec"), namespace)
    out = capsys.readouterr().out
    assert (tmp_path / "swing.png").stat().st_size > 30_000
    assert "plant.m1" in out and "timeout" in out
    assert namespace["obs"].summary()["min_rank_full"] == 4
    assert namespace["summary"]["samples"] == 4
    assert "estimator" in namespace["built"].systems and "ekf" not in namespace["built"].systems
    # the gyro integral's largest angle error (rad): measured 0.0579 at 1.3 m
    errors = [float(v) for v in re.findall(r"captured (0\.\d+)\n", out)]
    assert errors and errors[-1] == pytest.approx(0.058, abs=0.003)
