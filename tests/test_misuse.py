"""Misuse the package survives: each of the adversarial checks in
``tests/misuse_checks.py`` (which also runs them all as a script), through
the console entry point in a process of its own where the check is about
a process, and the smaller items: one line and the right exit status (2
bad input, 1 a fault, 128 + the signal), files whole, no worker left."""
import json
import signal
import subprocess
import sys

import pytest

import misuse_checks as checks


#: every adversarial check, by name
EVERY = checks.every_check()


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(EVERY))
def test_misuse_holds(name, tmp_path):
    """The check ``name`` holds: one line and the right exit status (2 bad
    input, 1 a fault, 128 + the signal), files whole, no worker left."""
    problem = EVERY[name](tmp_path)
    assert problem is None, problem


# ------------------------------------------------------- the smaller items
def test_a_solvers_output_on_descriptor_1_stays_off_json_stdout(tmp_path):
    """Under --json a message written straight to file descriptor 1 (SNOPT's
    'XXX Singular basis' from C++, a plug-in's os.write) goes to standard
    error: standard output is the JSON result alone."""
    spec = checks.plugin(tmp_path, "loud.py", "pass",
                        factory="os.write(1, b'XXX Singular basis\\n'); print('hello')")
    rc, out, err = checks.bplir("swing", "--controller", spec, "--no-animation", "--no-plots",
                               "--json", "--out", tmp_path / "s")
    assert rc == 0, err
    assert json.loads(out)["outcome"] in ("timeout", "crashed", "captured", "fell")
    assert "XXX Singular basis" in err and "hello" in err


def test_a_signal_while_the_finished_command_exits_is_one_line(tmp_path):
    """SIGTERM in the interpreter's teardown after the console's command has
    finished: one line saying the outputs are complete and exit 143, not a
    silent death by the signal (-15)."""
    code = ("import os, signal, sys, time\n"
            "sys.argv = ['bplir', 'params', 'plant']\n"
            "from bplir_drake.cli import main\n"
            "main()\n"
            "os.kill(os.getpid(), signal.SIGTERM)\n"
            "time.sleep(5)\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 128 + signal.SIGTERM
    assert p.stderr == "bplir: SIGTERM after the command had finished; its outputs are complete\n"


def test_a_second_signal_after_a_stopped_command_adds_no_line(tmp_path):
    """A process manager's second SIGTERM (``timeout`` passes its own on,
    a control group is signalled whole) arriving while a command a first
    SIGTERM stopped exits: the stop's one line and exit 143, not a second
    line saying the outputs are complete."""
    code = ("import os, signal, sys, time\n"
            "sys.argv = ['bplir', 'params', 'plant']\n"
            "from bplir_drake.cli import main, params_command\n"
            "def slow(args):\n"
            "    os.kill(os.getpid(), signal.SIGTERM)\n"
            "    time.sleep(5)\n"
            "params_command.cmd_params = slow\n"
            "code = main()\n"
            "os.kill(os.getpid(), signal.SIGTERM)\n"
            "time.sleep(5)\n"
            "sys.exit(code)\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.stderr == "bplir: terminated by SIGTERM; no output file was left half-written\n"
    assert p.returncode == 128 + signal.SIGTERM


@pytest.mark.parametrize("value", ["nan", "inf", "-inf"])
def test_a_plugin_argument_must_be_finite(value):
    """``--controller-arg k=nan`` is refused (it would reach the factory as NaN)."""
    from bplir_drake.params import ParameterError, plugin_arguments

    with pytest.raises(ParameterError, match="is not a finite number"):
        plugin_arguments([f"k={value}"])
    assert plugin_arguments(["k=2.5", "n=3", "on=true", "name=abc"]) == {
        "k": 2.5, "n": 3, "on": True, "name": "abc"}


def test_a_calibration_says_how_many_simulations_it_may_take(tmp_path, capsys):
    """``calibrate`` with its progress shown names the most simulations the
    fit may run and the time they take (from the first simulation)."""
    from bplir_drake.analysis.identification.calibration import read_calibration_csv
    from bplir_drake.analysis.identification.fit import MAX_FIT_STEPS, calibrate
    from bplir_drake.params import BplirParams

    p = BplirParams()
    log = read_calibration_csv(checks.angle_log(tmp_path, "log.csv"), p.motor.torque_per_amp,
                               min_duration=0.2)
    res = calibrate(p, log, ("fv1",), progress=True)
    err = capsys.readouterr().err
    assert f"at most {MAX_FIT_STEPS * 2} simulations of" in err
    assert res.nfev <= MAX_FIT_STEPS * 2
