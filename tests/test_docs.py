"""docs/python.md runs as written: its code blocks, in order, in one
namespace, in a temporary directory."""
import re
from pathlib import Path

import pytest

DOC = Path(__file__).resolve().parents[1] / "docs" / "python.md"


@pytest.mark.slow
def test_the_python_guide_runs(tmp_path, monkeypatch, capsys):
    blocks = re.findall(r"```python\n(.*?)```", DOC.read_text(), re.S)
    assert len(blocks) >= 7
    (tmp_path / "examples").mkdir()  # the guide runs from the project's root
    for example in ("my_estimator.py", "line_flat.toml"):
        (tmp_path / "examples" / example).write_text(
            (DOC.parents[1] / "examples" / example).read_text())
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__main__"}
    for i, code in enumerate(blocks):
        exec(compile(code, f"{DOC.name} block {i + 1}", "exec"), namespace)
    out = capsys.readouterr().out
    assert (tmp_path / "swing.png").stat().st_size > 30_000
    pdf = (tmp_path / "swing.pdf").read_bytes()   # TrueType text, no Type 3 fonts
    assert b"/FontFile2" in pdf and b"/Type3" not in pdf   # an embedded TrueType program
    assert namespace["trip"].summary()["totals"]["outcome"] == "passed"
    assert namespace["poles"].summary()["samples"] == 41
    assert "plant.m1" in out and "timeout" in out
    assert namespace["obs"].summary()["min_rank_full"] == 4
    assert namespace["summary"]["samples"] == 4
    assert "estimator" in namespace["built"].systems and "ekf" not in namespace["built"].systems
    # the gyro integral's largest angle error (rad): measured 0.0618
    errors = [float(v) for v in re.findall(r"captured (0\.\d+)\n", out)]
    assert errors and errors[-1] == pytest.approx(0.062, abs=0.003)


def test_the_api_page_runs(tmp_path, monkeypatch, capsys):
    """docs/api.md's code blocks run as written: the swing diagram wired
    into a user's diagram with a knock on its external_torque input
    still captures."""
    page = DOC.parent / "api.md"
    blocks = re.findall(r"```python\n(.*?)```", page.read_text(), re.S)
    assert blocks
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__main__"}
    for i, code in enumerate(blocks):
        exec(compile(code, f"{page.name} block {i + 1}", "exec"), namespace)
    assert capsys.readouterr().out.startswith("captured {'q1': ")


def test_the_readme_says_no_measured_figure_of_its_own():
    """Every measured figure of the README -- a rate, a capture speed, a
    count of swings, a speed-up -- is inside a block ``scripts/results_pages.py``
    generates from ``results/`` (which the test above checks); its prose
    and its status say what they mean without numbers of their own."""
    text = (DOC.parents[1] / "README.md").read_text()
    text = re.sub(r"<!-- ([a-z-]+) -->.*?<!-- /\1 -->", "", text, flags=re.S)
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    measured = [r"(?<!±)\b\d+(\.\d+)? ?%", r"\d+\.\d+ ?m/s", r"\b\d+ ?/ ?\d+\b(?! ?[a-z])",
                r"\d+(\.\d+)?(-\d+(\.\d+)?)? ?x real time", r"\bp\d\d \d", r"\b\d+ of \d+\b"]
    found = [m.group(0) for pattern in measured for m in re.finditer(pattern, text)]
    assert found == [], found


@pytest.mark.slow
def test_the_documentation_site_builds_without_warnings(tmp_path):
    """The site builds from docs/ with warnings as errors (the command the
    README names), and the parameter reference lists every parameter with
    its unit, range and default."""
    import subprocess
    import sys

    from bplir_drake.params import parameter_reference

    root = DOC.parents[1]
    run = subprocess.run([sys.executable, "-m", "sphinx", "-W", "-q", "-b", "html",
                          str(root / "docs"), str(tmp_path / "html")],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr[-3000:]
    page = (root / "docs" / "reference" / "parameters.md").read_text()
    sys.path.insert(0, str(root / "docs"))
    try:   # the committed page is what the build generates (readable without a build)
        import conf
        assert page == conf._parameters_page()
    finally:
        sys.path.remove(str(root / "docs"))
    rows = parameter_reference()
    assert len(rows) > 200
    for r in rows:
        assert f"| `{r['name']}` | {r['unit']} | {r['range']} |" in page, r
    html = (tmp_path / "html" / "reference" / "parameters.html").read_text()
    assert "supply_voltage" in html and "voltage_fraction" in html
    assert (tmp_path / "html" / "cli.html").read_text().count("--hardware") >= 5


def test_test_docstrings_say_what_they_check_in_a_few_lines():
    """A test's docstring says what it checks and why, in at most 8 lines;
    its history belongs to the changelog and git."""
    import ast

    for path in sorted((DOC.parents[1] / "tests").glob("*.py")):
        tree = ast.parse(path.read_text())
        for node in ast.walk(tree):
            if isinstance(node, (ast.FunctionDef, ast.Module)):
                doc = ast.get_docstring(node, clean=False)
                assert not doc or len(doc.splitlines()) <= 8, (path.name,
                                                               getattr(node, "name", ""))


@pytest.mark.slow
def test_the_results_pages_and_the_readme_table_match_the_stored_outputs():
    """Every figure of the README's results tables and of docs/results is
    what ``scripts/results_pages.py`` makes from the stored outputs in
    ``results/``: regenerating changes nothing."""
    import subprocess
    import sys

    root = DOC.parents[1]
    run = subprocess.run([sys.executable, str(root / "scripts" / "results_pages.py"), "--check"],
                         capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    readme = (root / "README.md").read_text()
    assert "| Realistic study, 0° line, default robot (1000 swings) |" in readme
    assert "| 30 V, line sensor |" in readme


def test_every_stored_output_can_be_run_again_beside_itself(tmp_path):
    """``scripts/rerun_results.py`` stages each manifest command away from
    the stored output: the staged command names neither the stored
    directory nor a study inside it (a study kept there is read from a
    copy, which is made), and writes under the stage; a robot commissioned
    not ready (exit 1, its report written) counts as finished."""
    import importlib.util

    root = DOC.parents[1]
    spec = importlib.util.spec_from_file_location("rerun_results",
                                                  root / "scripts" / "rerun_results.py")
    rr = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(rr)
    items = rr.entries()
    assert len(items) == 61
    for k, item in enumerate(items):
        target, stage, kept = rr.out_dir(item), tmp_path / f"s{k}", tmp_path / f"k{k}"
        command = rr.staged(item, stage, kept)
        assert f"{target} " not in command + " " and f"{target}/" not in command, command
        assert str(stage) in command, command
    kept_study = tmp_path / "k17" / "study.toml"   # landing/imu-true-lengths reads its own study
    assert items[17]["path"] == "landing/imu-true-lengths" and kept_study.is_file()
    # finished: exit 0, or a commissioning's exit 1 (not ready) with its report written
    assert rr.finished(0, tmp_path) and not rr.finished(1, tmp_path)
    (tmp_path / "commission.json").write_text("{}")
    assert rr.finished(1, tmp_path) and not rr.finished(2, tmp_path)


def test_the_readme_is_a_front_door():
    """At most 300 lines, nothing dated, the two quick-start commands, and
    every local link pointing at a file of the repository."""
    import re

    root = DOC.parents[1]
    text = (root / "README.md").read_text()
    assert len(text.splitlines()) <= 300
    assert not re.search(r"\b20\d\d-\d\d-\d\d\b", text)
    assert ".venv/bin/bplir swing" in text and "<!-- test-command -->" in text
    for target in re.findall(r"\]\(([^)#]+)(?:#[^)]*)?\)", text):
        if "://" not in target:
            assert (root / target).exists(), target
