"""Adversarial checks of what a user gives the package (the fourth round
of misuse): hand-edited study tables resumed, physical fields without a
bound, deeply nested TOML, seeds through the API, a replay window at its
floor, a 20 MB value in an error line, a plan solve that never ends.  Each
returns None when it holds, else what broke; ``test_misuse.py`` runs them."""
from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import time
from pathlib import Path

from misuse_checks import angle_log, bplir, first, one_error_line, tiny_robot

#: hand edits of a finished study's results.csv: {what: (column, value)}
#: (a column of None: the row cut short; "+": a cell added)
TABLE_EDITS = {"success 'maybe'": ("success", "maybe"),
               "a capture speed of 1e300": ("capture_speed_mps", "1e300"),
               "an outcome its success denies": ("outcome", "crash"),
               "a drawn mass not its sample's": ("true_friction.fv1", "0.5"),
               "a figure that is a word": ("peak_torque_Nm", "lots"),
               "a row cut short": (None, ""),
               "a cell added": ("+", "1.0")}


def _edit(table: Path, row: int, column, value) -> None:
    rows = list(csv.reader(table.open(newline="")))
    if column is None:
        rows[row] = rows[row][:5]
    elif column == "+":
        rows[row] = rows[row] + [value]
    else:
        rows[row][rows[0].index(column)] = value
    with table.open("w", newline="") as fh:
        csv.writer(fh).writerows(rows)


def a_hand_edited_study_table_is_recomputed(d: Path):
    """Each of :data:`TABLE_EDITS` in a finished 3-swing study, resumed: one
    note naming the damaged row and why, the sample run again, and the
    summary that of the study unedited."""
    study = ["montecarlo", "-n", "3", "--workers", "1", "--no-plots", "--json", "--out",
             d / "mc"]
    rc, out, err = bplir(*study)
    if rc != 0:
        return f"first run: exit {rc} {err[-300:]!r}"
    before = json.loads(out)
    table = d / "mc" / "results.csv"
    for what, (column, value) in TABLE_EDITS.items():
        _edit(table, 2, column, value)
        rc, out, err = bplir(*study)
        notes = [x for x in err.splitlines() if "damaged row" in x]
        after = json.loads(out) if rc == 0 else {}
        same = {k: after.get(k) for k in ("captured", "capture_speed_p95_mps", "outcomes")} == \
            {k: before.get(k) for k in ("captured", "capture_speed_p95_mps", "outcomes")}
        if rc != 0 or len(notes) != 1 or "1 damaged row run again: line 3" not in notes[0] \
                or not same:
            return f"{what}: exit {rc}, notes {notes}, summary {after.get('captured')}"
    return None


def physical_fields_have_upper_bounds(d: Path):
    """m1 = 1e300, I2 = 1e300, a resistance of 1e300 ohm and a capture band
    of 1e300 m: one line naming the field and its range, exit 2."""
    for field, words in (("plant.m1", "(0, 1000]"), ("plant.I2", "(0, 100000]"),
                         ("motor.resistance", "(0, 1000]"),
                         ("gripper.capture_distance", "(0, 10]")):
        rc, _, err = bplir("commission", Path(__file__).resolve().parents[1] / "examples" /
                           "commission" / "bplir.toml", "--set", f"{field}=1e300",
                           "--out", d / "c")
        problem = one_error_line(rc, err, 2, f"{field} = 1e+300 is out of range", words)
        if problem:
            return f"{field}: {problem}"
    return None


def deeply_nested_toml_is_bad_input(d: Path):
    """A robot file nested 3000 deep (arrays, inline tables): one line naming
    the file, exit 2 -- not a RecursionError."""
    for name, text in (("arrays", "x = " + "[" * 3000 + "]" * 3000 + "\n"),
                       ("tables", "[plant]\nm1 = " + "{a = " * 5000 + "1" + "}" * 5000 + "\n")):
        (d / f"{name}.toml").write_text(text)
        rc, _, err = bplir("params", "--config", d / f"{name}.toml")
        problem = one_error_line(rc, err, 2, f"{name}.toml nests its tables and arrays deeper")
        if problem:
            return f"{name}: {problem}"
    return None


def a_sample_seed_is_checked_on_the_api(d: Path):
    """``set_swing_sample`` takes a seed in [0, 2^32) only: 2**40, "3",
    True, -1, 1.5, NaN and None are a ParameterError saying so."""
    from bplir_drake.diagrams.swing import build_swing, set_swing_sample
    from bplir_drake.params import BplirParams, ParameterError

    p = BplirParams()
    built = build_swing(p)
    context = built.diagram.CreateDefaultContext()
    for seed in (2 ** 40, "3", True, -1, 1.5, float("nan"), None):
        try:
            set_swing_sample(built, context, p, seed)
        except ParameterError as exc:
            if "is not a seed" not in str(exc):
                return f"seed {seed!r}: {exc}"
            continue
        except Exception as exc:   # noqa: BLE001 - numpy's own error is the class broken
            return f"seed {seed!r}: {type(exc).__name__}: {exc}"
        return f"seed {seed!r} was taken"
    set_swing_sample(built, context, p, 7)
    return None


def a_replay_window_of_two_samples_is_taken(d: Path):
    """``replay --window 0.01`` on a 200 Hz log is two sampling periods:
    taken, not refused as below 0.010000000000000009."""
    log = angle_log(d, "log100.csv")
    lines = log.read_text().splitlines()
    rows = [r.split(",") for r in lines[1:]]
    fast = ["t,q1,q2,tau"] + [",".join([repr(float(r[0]) / 2)] + r[1:]) for r in rows]
    (d / "log200.csv").write_text("\n".join(fast) + "\n")
    rc, _, err = bplir("replay", d / "log200.csv", "--window", "0.01", "--out", d / "r")
    return None if rc == 0 else f"exit {rc}: {err[-300:]!r}"


def a_huge_value_is_cut_in_its_error_line(d: Path):
    """A 20 MB robot.file string: one error line under 1000 characters that
    names the field and says how much was cut."""
    (d / "big.toml").write_text('[robot]\nfile = "' + "x" * 20_000_000 + '"\n')
    rc, _, err = bplir("params", "--config", d / "big.toml")
    return first(one_error_line(rc, err, 2, "robot.file", "characters cut"),
                 None if len(err) < 1000 else f"the line is {len(err)} characters")


def a_swing_that_cannot_plan_meets_the_wall_limit(d: Path):
    """A swing of the 1e-9 kg link robot, whose plan SNOPT solves for
    minutes: the wall-clock limit stops the solve with one line saying so."""
    config = tiny_robot(d)
    with open(config, "a") as fh:
        fh.write("[scenario]\nwall_limit = 5\n[friction]\nfv1 = 0.0\nfv2 = 0.0\nfc1 = 0.0\n"
                 "fc2 = 0.0\n")
    rc, _, err = bplir("swing", "--config", config, "--path-mode", "plan", "--no-animation",
                       "--no-plots", "--out", d / "s", timeout=120,
                       env={"BPLIR_CACHE_DIR": d / "cache"})
    return one_error_line(rc, err, 1, "planning the swing of seed", "ran past its wall-clock "
                          "limit of 5 s", "bplir commission")


def a_killed_writers_temporary_file_is_swept(d: Path):
    """A writer killed with SIGKILL leaves ``.motion-PID-XXXXXXXX.f64`` in
    --out: the next command into that --out removes it (its writer is
    gone), as it does an old ``.motion-XXXXXXXX.f64`` an hour old, and
    keeps a live writer's."""
    out = d / "out"
    out.mkdir()
    dead = subprocess.Popen([sys.executable, "-c", "pass"])
    dead.wait()
    killed = out / f".motion-{dead.pid}-abcd1234.f64"
    old = out / ".motion-abcd1234.f64"
    live = out / f".motion-{os.getpid()}-abcd1234.f64"
    for f in (killed, old, live):
        f.write_bytes(b"\0" * 64)
    os.utime(old, (time.time() - 7200, time.time() - 7200))
    rc, _, err = bplir("freeswing", "--duration", "0.05", "--out", out)
    if rc != 0:
        return f"exit {rc}: {err[-300:]!r}"
    left = sorted(p.name for p in out.glob(".motion-*"))
    return None if left == [live.name] else f"left in --out: {left}"


#: every check, by what it guards
CHECKS = {f.__name__: f for f in (
    a_hand_edited_study_table_is_recomputed,
    physical_fields_have_upper_bounds,
    deeply_nested_toml_is_bad_input,
    a_sample_seed_is_checked_on_the_api,
    a_replay_window_of_two_samples_is_taken,
    a_huge_value_is_cut_in_its_error_line,
    a_swing_that_cannot_plan_meets_the_wall_limit,
    a_killed_writers_temporary_file_is_swept,
)}
