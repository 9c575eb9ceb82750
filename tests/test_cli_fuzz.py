"""Fuzzing the command line: any command with any of its options and any
value -- empty, huge, NaN, negative, text, a missing file, a malformed
``--set`` -- ends in a result or one ``bplir: error:`` line, never a
traceback.  The work itself (a simulation, a plan solve, a study) is
stopped where it would start: what is fuzzed is everything before it.
The readers' own fuzz is in test_hardening.py."""

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from bplir_drake import cli
from conftest import ENDINGS, ends_cleanly, stopped_work  # noqa: F401 (the fixture)

VALUES = ["", "0", "-1", "1", "2.5", "1e300", "-1e300", "nan", "inf", "-inf", "abc", "1,2",
          "0,0,0,0", "nan,0", "1e300,0", "/nonexistent/file.toml", ".", "plan", "qft",
          "dissertation", "shoot", "line-sensor", "48v,line-sensor", "nope:make",
          "plant.m2=1.6", "plant.m2=nan", "plant.m2", "nosuch.field=1", "scenario.seed=-3",
          "scenario.wall_limit=0", "motor.envelope=maybe", "estimator.period=1e-9", "fv1,fv1",
          "png", "svg", "30", "1e-9", "x" * 300, "é", "--"]


def _commands():
    parser = cli.build_parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    table = {}
    for name, p in sub.choices.items():
        opts = [a for a in p._actions if a.option_strings and "-h" not in a.option_strings]
        positional = [a for a in p._actions if not a.option_strings]
        table[name] = ([(a.option_strings[-1], a.nargs == 0) for a in opts], len(positional))
    return table


COMMANDS = _commands()


@st.composite
def command_lines(draw):
    name = draw(st.sampled_from(sorted(COMMANDS)))
    options, positional = COMMANDS[name]
    argv = [name] + [draw(st.sampled_from(VALUES)) for _ in range(positional)]
    for opt, flag in draw(st.lists(st.sampled_from(options), max_size=5)):
        argv += [opt] if flag else [opt, draw(st.sampled_from(VALUES))]
    return argv


@pytest.mark.slow
@settings(max_examples=150, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(argv=command_lines())
def test_no_command_line_ends_in_a_traceback(stopped_work, argv):
    assert ends_cleanly(argv) in ENDINGS
