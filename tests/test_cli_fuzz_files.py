"""Fuzzing the files the command line reads: robot descriptions, logs
replayed or calibrated against, and plan files -- each generated from a
good one with numbers, attributes and rows broken -- end in a result or
one ``bplir: error:`` line (exit 1 or 2), never a traceback.  The work
itself is stopped where it would start (``stopped_work``); what is
fuzzed is the reading and checking before it."""
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from conftest import ENDINGS, ends_cleanly, stopped_work  # noqa: F401 (the fixture)

ROBOT = (Path(__file__).resolve().parents[1] / "bplir_drake" / "data" / "robots"
         / "bplir.urdf").read_text()
NUMBERS = ["0", "-1", "1e-9", "1e300", "-1e300", "nan", "inf", "-inf", "abc", "", "1 2",
           "0 0 0 0", "0 0 nan", "1e-300", "3", "0.5"]
FUZZ = settings(max_examples=200, deadline=None, derandomize=True,
                suppress_health_check=[HealthCheck.function_scoped_fixture,
                                       HealthCheck.too_slow])


@st.composite
def robot_files(draw):
    """The default robot's URDF with up to four of its attribute values
    replaced, an element's name changed, or the text cut short."""
    text = ROBOT
    spots = [i for i in range(len(text)) if text.startswith('="', i)]
    for _ in range(draw(st.integers(0, 4))):
        at = draw(st.sampled_from(spots))
        end = text.index('"', at + 2)
        text = text[:at + 2] + draw(st.sampled_from(NUMBERS)) + text[end:]
        spots = [i for i in range(len(text)) if text.startswith('="', i)]
    how = draw(st.sampled_from(["values", "cut", "rename", "type"]))
    if how == "cut":
        text = text[:draw(st.integers(0, len(text)))]
    elif how == "rename":
        text = text.replace(draw(st.sampled_from(['"link2"', '"elbow_joint"', '"free_gripper"',
                                                  "<inertia ", "<mass "])), '"other"', 1)
    elif how == "type":
        kind = draw(st.sampled_from(["fixed", "prismatic", "revolute", "floating", "x"]))
        text = text.replace('type="continuous"', f'type="{kind}"', 1)
    return text


@FUZZ
@given(text=robot_files(), command=st.sampled_from(["params", "freeswing", "model"]))
def test_no_robot_file_ends_in_a_traceback(stopped_work, text, command):
    Path("robot.urdf").write_text(text)
    Path("robot.toml").write_text('[robot]\nfile = "robot.urdf"\n')
    argv = {"params": ["params", "plant"], "freeswing": ["freeswing", "--duration", "0.1"],
            "model": ["model", "--json"]}[command]
    assert ends_cleanly(argv + ["--config", "robot.toml"]) in ENDINGS


CELLS = ["0.1", "0", "-1", "nan", "inf", "1e300", "1000", "abc", "", "1e-9", "0.5"]


@st.composite
def logs(draw):
    """A 1.4 s log of t, q1, q2, tau at 100 Hz with cells, rows or the
    header broken, the clock jumping or repeating."""
    t = np.arange(140) * 0.01
    data = np.c_[t, 0.3 * np.cos(2.7 * t), 0.1 * np.sin(3 * t), np.full(140, 0.5)]
    how = draw(st.sampled_from(["cells", "jump", "repeat", "short", "header", "extra"]))
    if how == "jump":
        data[draw(st.integers(1, 139)):, 0] += draw(st.sampled_from([0.02, 0.2, 5.0, 1e6, -1.0]))
    rows = [[repr(float(v)) for v in r] for r in data]
    for _ in range(draw(st.integers(0, 3))):
        rows[draw(st.integers(0, 139))][draw(st.integers(0, 3))] = draw(st.sampled_from(CELLS))
    header = "t,q1,q2,tau"
    if how == "repeat":
        k = draw(st.integers(0, 138))
        rows.insert(k, list(rows[k]))
    elif how == "short":
        rows = rows[:draw(st.integers(0, 25))]
    elif how == "header":
        header = draw(st.sampled_from(["t,q1,q2", "time,q1,q2,tau", "t,q1,q2,i_cmd",
                                       "t,q1,q1,tau", "", "t;q1;q2;tau"]))
    elif how == "extra":
        rows = [r + [draw(st.sampled_from(CELLS))] for r in rows]
    return "\n".join([header] + [",".join(r) for r in rows]) + "\n"


@FUZZ
@given(text=logs(), command=st.sampled_from(["replay", "calibrate"]),
       window=st.sampled_from([None, "1e-9", "0.005", "0.5", "nan", "600", "1e9"]))
def test_no_log_ends_in_a_traceback(stopped_work, text, command, window):
    Path("log.csv").write_text(text)
    assert ends_cleanly([command, "log.csv"]
                        + (["--window", window] if window and command == "replay" else [])) \
        in ENDINGS


@st.composite
def plan_files(draw):
    """A 1 s plan of t, q1, q2, q1d, q2d, tau with cells, rows, times or
    the named columns broken."""
    t = np.linspace(0.0, 1.0, 40)
    data = np.c_[t, 0.3 * t, -0.5 * t, np.full(40, 0.3), np.full(40, -0.5), np.full(40, 1.0)]
    how = draw(st.sampled_from(["cells", "late", "gap", "reverse", "short", "columns"]))
    if how == "gap":
        data[draw(st.integers(1, 39)):, 0] += draw(st.sampled_from([0.9, 1.5, 30.0]))
    rows = [[repr(float(v)) for v in r] for r in data]
    for _ in range(draw(st.integers(0, 3))):
        rows[draw(st.integers(0, 39))][draw(st.integers(0, 5))] = draw(st.sampled_from(CELLS))
    columns = '["t", "q1", "q2", "q1d", "q2d", "tau"]'
    if how == "late":
        rows[-1][0] = draw(st.sampled_from(["1e9", "61", "59.5", "1e300"]))
    elif how == "reverse":
        rows = rows[::-1]
    elif how == "short":
        rows = rows[:draw(st.integers(0, 12))]
    elif how == "columns":
        columns = draw(st.sampled_from(['["t", "q1", "q2", "q1d", "q2d", "t"]',
                                        '["t", "q1", "q2", "q1d", "q2d"]',
                                        '["t", "q1", "q2", "q1d", "q2d", "nope"]', '[]']))
    return "\n".join(["t,q1,q2,q1d,q2d,tau"] + [",".join(r) for r in rows]) + "\n", columns


@pytest.mark.slow
@FUZZ
@given(plan=plan_files())
def test_no_plan_file_ends_in_a_traceback(stopped_work, monkeypatch, plan):
    from bplir_drake.planning import solve as planning
    from conftest import _stop

    monkeypatch.setattr(planning, "tracking_gains", _stop)   # the LQR is the work
    text, columns = plan
    Path("plan.csv").write_text(text)
    Path("plan.toml").write_text(f'[plan]\nfile = "plan.csv"\nfile_columns = {columns}\n')
    assert ends_cleanly(["swing", "--config", "plan.toml", "--no-animation"]) in ENDINGS
