"""Parameter blocks: defaults from the dissertation, validation, presets, TOML."""
import dataclasses as dc
import json
import math

from bplir_drake.params.blocks import MAX_MASS

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from bplir_drake import params as P
from forked import bplir_forked


def test_table_4_3_defaults(params):
    p, f = params.plant, params.friction
    assert (p.m1, p.m2, p.l1, p.l2) == (3.2287, 1.5155, 0.9091, 1.2451)
    assert (p.lc1, p.lc2, p.I1, p.I2) == (0.2167, 0.5459, 0.1539, 0.2191)
    assert (f.fv1, f.fv2, f.fc1, f.fc2, f.b) == (0.1706, 0.0765, 0.0124, 0.7681, 0.01)


def test_motor_torque_constant_consistent_with_deadband_and_limit(params):
    m = params.motor
    # 15 A is the theoretical 20 N m; 0.63 A is the 0.82336 N m dead-band (4.14)
    assert m.torque_per_amp * 15.0 == pytest.approx(20.0, rel=0.01)
    assert m.torque_per_amp * 0.63 == pytest.approx(0.82336, rel=0.02)


def test_lab_preset_geometry():
    lab = P.preset("lab")
    assert (lab.estimator.r1, lab.estimator.r2, lab.estimator.l1) == (0.5, 0.5, 0.8)
    assert lab.controller.preset == "lab"
    assert lab.plant == P.preset("dissertation").plant


@pytest.mark.parametrize("block, kwargs, words", [
    (P.PlantParams, {"m1": -1.0}, ["plant.m1", "(0, 1000]"]),
    (P.PlantParams, {"lc1": 1.0}, ["plant.lc1", "plant.l1"]),
    (P.PlantParams, {"lc2": 2.0}, ["plant.lc2"]),
    (P.PlantParams, {"I2": math.nan}, ["plant.I2", "not finite"]),
    (P.FrictionParams, {"fc2": -0.1}, ["friction.fc2"]),
    (P.FrictionParams, {"b": 0.0}, ["friction.b"]),
    (P.MotorParams, {"tau_current": 0.05}, ["motor.tau_current", "0.01"]),
    (P.MotorParams, {"i_cont": 20.0}, ["motor.i_cont"]),
    (P.ImuParams, {"misalign1": 1.0}, ["imu.misalign1"]),
    (P.ScenarioParams, {"incline_deg": 90.0}, ["scenario.incline_deg", "90"]),
    (P.ScenarioParams, {"seed": -3}, ["scenario.seed"]),
    (P.ControllerParams, {"preset": "pid"}, ["controller.preset", "plan"]),
    (P.LandingParams, {"landing_law": "lqr"}, ["landing.landing_law", "auto, shoot, aim, reach, none"]),
    (P.TraverseParams, {"swing_mode": "x"}, ["traverse.swing_mode", "adaptive"]),
])
def test_bad_parameters_name_field_and_range(block, kwargs, words):
    with pytest.raises(P.ParameterError) as err:
        block(**kwargs)
    msg = str(err.value)
    assert "\n" not in msg
    for w in words:
        assert w in msg


def test_imu_must_sit_on_the_link():
    with pytest.raises(P.ParameterError, match="imu.r1"):
        P.BplirParams(imu=P.ImuParams(r1=1.5))


def test_unknown_preset():
    with pytest.raises(P.ParameterError, match="unknown preset 'x'; allowed: dissertation, lab"):
        P.preset("x")


def test_toml_round_trip(tmp_path, params):
    changed = params.with_(plant=P.PlantParams(m1=3.0),
                           true_friction=params.friction.scaled(1.2, 0.8))
    path = tmp_path / "p.toml"
    P.save_toml(changed, path)
    back = P.load_toml(path)
    assert back == changed
    assert back.simulated_friction.fc2 == pytest.approx(0.7681 * 0.8)
    assert back.friction.fc2 == 0.7681  # the nominal model is untouched


@pytest.mark.parametrize("text, words", [
    ("[plant\nm1 = 1", "malformed TOML"),
    ("[plnt]\nm1 = 1\n", "unknown parameter table '[plnt]'"),
    ("[plant]\nmass = 1\n", "unknown parameter 'plant.mass'"),
    ("[plant]\nm1 = 'heavy'\n", "plant.m1 = 'heavy' is not a number"),
    ("preset = 'moon'\n", "unknown preset 'moon'"),
    ("plant = 3\n", "'plant' must be a table"),
])
def test_malformed_toml(tmp_path, text, words):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(P.ParameterError) as err:
        P.load_toml(path)
    assert words in str(err.value)


@settings(max_examples=60, deadline=None)
@given(m=st.floats(allow_nan=True, allow_infinity=True))
def test_any_mass_is_accepted_or_rejected_cleanly(m):
    try:
        p = P.PlantParams(m1=m)
    except P.ParameterError as exc:
        assert "plant.m1" in str(exc)
        assert not (0 < m <= MAX_MASS)
    else:
        assert 0 < p.m1 <= MAX_MASS


def test_every_parameter_says_what_it_means_in_a_line_or_two():
    """Each parameter has a doc of its own, at most 300 characters, with no
    tuning diary (no dates) in it."""
    import re

    from bplir_drake.params import parameter_reference

    for r in parameter_reference():
        name = f"{r['block']}.{r['name']}"
        assert r["doc"], name
        assert len(r["doc"]) <= 300, name
        assert not re.search(r"\b20\d\d-\d\d-\d\d\b", r["doc"]), name


def test_nothing_refers_to_files_outside_the_repository():
    """The package, its tests, examples, benchmarks and docs are
    self-contained: no reference to the developers' private notes."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    outside = ("SPEC" + ".md", "ENGINEERING" + ".md", "../" + "shared")
    for folder in ("bplir_drake", "tests", "examples", "benchmarks", "docs", "scripts"):
        for path in (root / folder).rglob("*"):
            if path.suffix in (".py", ".md", ".toml") and "_build" not in path.parts:
                text = path.read_text(encoding="utf-8")
                for word in outside:
                    assert word not in text, (path, word)
    for name in ("README.md", "ARCHITECTURE.md", "CHANGELOG.md"):
        for word in outside:
            assert word not in (root / name).read_text(encoding="utf-8"), (name, word)


def test_the_command_line_names_its_version_lists_and_sets_parameters(capsys):
    """``bplir --version``; ``bplir params --json`` lists every parameter with
    unit, range, value and meaning, the values in force after ``--hardware``
    and ``--set``; a bad ``--set`` is one line, exit 2."""
    import json

    from bplir_drake.cli import main
    from bplir_drake.params import parameter_reference

    with pytest.raises(SystemExit) as ex:
        main(["--version"])
    assert ex.value.code == 0 and capsys.readouterr().out.startswith("bplir ")
    assert main(["params", "--json", "--hardware", "48v", "--set", "plant.m2=1.6",
                 "--set", "landing.landing_law=aim"]) == 0
    rows = {f"{r['block']}.{r['name']}": r for r in json.loads(capsys.readouterr().out)["parameters"]}
    assert len(rows) == len(parameter_reference())
    assert rows["plant.m2"]["value"] == 1.6 and rows["plant.m2"]["unit"] == "kg"
    assert rows["motor.supply_voltage"]["value"] == 48.0
    assert rows["landing.landing_law"]["value"] == "aim"
    assert rows["motor.resistance"]["range"] == "(0, 1000]"
    for bad, words in ((["--set", "plant.m2=-1"], "plant.m2 = -1 is out of range"),
                       (["--set", "plant=1"], "must be block.field=value")):
        assert main(["params", *bad]) == 2
        assert words in capsys.readouterr().err


def test_former_controller_preset_names_are_accepted_with_a_notice(tmp_path):
    """``qft`` and ``dissertation`` (the former names of ``plan`` and
    ``cpfl-qft``) still load, from Python with a FutureWarning and from the
    command line with one ``bplir: note:`` line."""

    with pytest.warns(FutureWarning, match="'qft' is now called 'plan'"):
        assert P.ControllerParams(preset="qft").preset == "plan"
    with pytest.warns(FutureWarning, match="'dissertation' is now called 'cpfl-qft'"):
        assert P.BplirParams().with_controller("dissertation").controller.preset == "cpfl-qft"
    config = tmp_path / "old.toml"
    config.write_text("[controller]\npreset = 'qft'\n")
    rc, out, err = bplir_forked("params", "controller", "--config", config, "--json")
    assert rc == 0
    assert err == "bplir: note: controller preset 'qft' is now called 'plan'\n"
    assert '"plan"' in out


@pytest.mark.slow
def test_the_console_script_versions_lists_sets_and_passes_plugin_arguments(tmp_path):
    """Through the installed ``bplir`` console script itself: ``--version``,
    ``params --json``, a swing with ``--set plant.m2=1.6`` (the swing ran
    with it) and a plug-in given an argument (it flew with it)."""
    import json
    import shutil
    import subprocess
    import sys
    from pathlib import Path

    exe = shutil.which("bplir", path=str(Path(sys.executable).parent)) or shutil.which("bplir")
    assert exe, "the bplir console script is installed with the package"

    def bplir(*argv):
        p = subprocess.run([exe, *map(str, argv)], capture_output=True, text=True, timeout=300)
        assert p.returncode == 0, p.stderr
        return p.stdout

    assert bplir("--version").startswith("bplir ")
    rows = json.loads(bplir("params", "--json"))["parameters"]
    assert {"block", "name", "unit", "range", "value", "doc"} <= set(rows[0])
    swing = json.loads(bplir("swing", "--set", "plant.m2=1.6", "--no-animation", "--no-plots", "--json",
                             "--out", tmp_path / "s"))
    saved = json.loads((tmp_path / "s" / "summary.json").read_text())
    assert swing["outcome"] in ("captured", "crash", "short", "fall", "timeout")
    assert saved["parameters"]["plant"]["m2"] == 1.6
    plugin = tmp_path / "hold.py"
    plugin.write_text(
        "from pydrake.systems.framework import LeafSystem\n"
        "class Hold(LeafSystem):\n"
        "    def __init__(self, torque):\n"
        "        super().__init__()\n"
        "        self.DeclareVectorInputPort('state', 4)\n"
        "        self.DeclareVectorOutputPort('torque', 1, lambda c, o: o.SetAtIndex(0, torque))\n"
        "def make(params, torque=0.0):\n"
        "    return Hold(torque)\n")
    held = json.loads(bplir("swing", "--controller", f"{plugin}:make", "--controller-arg",
                            "torque=1.25", "--no-animation", "--no-plots", "--json", "--out", tmp_path / "p"))
    assert held["controller"] == "hold:make" and abs(held["peak_torque_Nm"] - 1.25) < 1e-9


def test_counts_are_whole_numbers():
    """Counts (samples, ticks) are integers: a file's ``500.0`` is read as 500,
    ``12.5`` ticks is one line naming the field and its range."""
    est = dc.replace(P.EstimatorParams(), standstill_samples=500.0)
    assert est.standstill_samples == 500 and type(est.standstill_samples) is int
    assert type(P.BplirParams().plan.delay_window) is int
    assert type(P.preset("lab").controller.delay_samples) is int
    with pytest.raises(P.ParameterError, match=r"plan.delay_window = 12.5 is not a whole "
                                               r"number; allowed whole numbers in \[8, 50\]"):
        dc.replace(P.PlanParams(), delay_window=12.5)


def test_the_path_table_is_split_into_path_plan_and_landing(tmp_path):
    """The path generator keeps ``[path]``; plan tracking is ``[plan]`` and its
    landing laws ``[landing]``.  A file written before the split (plan and
    landing fields in ``[path]``, ``plan_`` prefixed) still loads into the
    new blocks with one notice, and so does ``--set path.shoot_height``."""

    names = {b: {f.name for f in dc.fields(P.BLOCKS[b])} for b in ("path", "plan", "landing")}
    assert not names["path"] & (names["plan"] | names["landing"])
    assert {"mode", "blend_exponent", "pump_gain"} <= names["path"]
    assert {"end_depth", "indexing", "delay_probe"} <= names["plan"]
    assert {"landing_law", "shoot_height", "reach_speed"} <= names["landing"]
    old = tmp_path / "old.toml"
    old.write_text("[path]\nmode = 'plan'\nplan_indexing = 'state'\nshoot_height = -0.01\n")
    with pytest.warns(FutureWarning, match=r"now in \[plan\]"):
        p = P.load_toml(old)
    assert (p.path.mode, p.plan.indexing, p.landing.shoot_height) == ("plan", "state", -0.01)
    rc, out, err = bplir_forked("params", "landing", "--json", "--set",
                                "path.shoot_height=-0.012")
    assert rc == 0
    assert err == "bplir: note: --set path.shoot_height is now --set landing.shoot_height\n"
    rows = {r["name"]: r for r in json.loads(out)["parameters"]}
    assert rows["shoot_height"]["value"] == -0.012


def test_the_imus_keep_their_place_along_shorter_links(tmp_path, capsys):
    """A file giving a 0.34 m robot (DFKI's AcroMonk scale) and no IMU
    positions: the IMUs and the filter's geometry keep their place along the
    links (0.5 m of 0.9091 m becomes 0.187 m of 0.34 m) instead of refusing
    the default 0.5 m radii; a radius the file gives is kept; ``bplir model``
    runs on it."""
    from bplir_drake.cli import main

    text = ("[plant]\nm1 = 0.63\nm2 = 0.63\nl1 = 0.34\nl2 = 0.34\nlc1 = 0.18\nlc2 = 0.16\n"
            "I1 = 0.0017\nI2 = 0.0017\n")
    (tmp_path / "small.toml").write_text(text)
    p = P.load_toml(tmp_path / "small.toml")
    d = P.BplirParams()
    assert p.imu.r1 == pytest.approx(d.imu.r1 * 0.34 / d.plant.l1)
    assert p.imu.r2 == pytest.approx(d.imu.r2 * 0.34 / d.plant.l2)
    assert (p.estimator.r1, p.estimator.r2, p.estimator.l1) == pytest.approx(
        (p.imu.r1, p.imu.r2, 0.34))
    (tmp_path / "given.toml").write_text(text + "[imu]\nr1 = 0.3\n")
    assert P.load_toml(tmp_path / "given.toml").imu.r1 == 0.3
    assert main(["model", "--config", str(tmp_path / "small.toml"), "--no-swing",
                 "--out", str(tmp_path / "m")]) == 0
    assert "hanging eigenvalues" in capsys.readouterr().out


def test_retired_fields_load_and_say_when_their_value_is_ignored():
    """A file written before a variant field was retired still loads: the
    field is dropped silently where its value is the one that decides now
    (the swapped robot's shot height was always the landing's), with one
    warning naming it and what decides where it is not."""
    import warnings

    from bplir_drake.params import from_dict
    from bplir_drake.params.retired import RETIRED

    same = {"traverse": {"swapped_shoot_height": -0.015, "swapped_landing_law": "auto"},
            "estimator": {"loop_gyro_meas_sigma": 0.0166}, "plan": {"hanging_rate_limit": 0.0}}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert from_dict(same) == P.BplirParams()
    with pytest.warns(FutureWarning, match=r"traverse.swapped_shoot_rate_cap = 0.0 "
                                           r"\(now landing.shoot_rate_cap \(0.3\)\)"):
        p = from_dict({"traverse": {"swapped_shoot_rate_cap": 0.0}})
    assert p.landing.shoot_rate_cap == 0.3
    names = {r["name"] for r in P.parameter_reference()}
    assert not {n for _, n in RETIRED} & names
    assert len(P.parameter_reference()) < 243


def test_a_file_with_the_two_filter_tunings_loads_the_swings():
    """A file written when ``[estimator]`` held the offline tuning beside the
    swing's ``loop_*`` fields loads as the swing's filter (its values decide);
    its dissertation values are ``chapter5()``'s, silently; an offline value
    of its own is named as ignored."""
    import warnings

    from bplir_drake.params import from_dict

    old = {"accel_process_sigma": 0.427, "gyro_meas_sigma": 0.02, "accel_meas_sigma": 0.427,
           "integration": "euler", "estimate_misalignment": False,
           "loop_accel_process_sigma": 2.0, "loop_accel_meas_sigma": 0.05,
           "loop_integration": "trapezoid", "loop_estimate_misalignment": False,
           "tuned_gyro_noise": 0.03}
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        e = from_dict({"estimator": old}).estimator
    assert (e.accel_process_sigma, e.accel_meas_sigma, e.integration, e.gyro_meas_sigma,
            e.estimate_misalignment) == (2.0, 0.05, "trapezoid", 0.03, False)
    assert e.chapter5() == dc.replace(e, accel_process_sigma=0.427, accel_meas_sigma=0.427,
                                      gyro_meas_sigma=0.02, integration="euler")
    with pytest.warns(FutureWarning, match=r"estimator.accel_process_sigma = 0.5 \(the offline"):
        e = from_dict({"estimator": old | {"accel_process_sigma": 0.5}}).estimator
    assert e.accel_process_sigma == 2.0
    d = P.BplirParams().estimator   # the defaults: the swing's filter as it was
    assert (d.accel_process_sigma, d.accel_meas_sigma, d.integration, d.gyro_meas_sigma,
            d.estimate_misalignment) == (0.2, 0.1, "heun", 0.0166, True)


def test_every_stored_study_loads_as_it_was_run():
    """Each study file under results/ (written before fields moved or were
    retired) still loads, its moved fields where they are now: the 48 V
    tries' supply in ``[hanging]``, the filter of the swing as it ran."""
    import warnings
    from pathlib import Path

    from bplir_drake.analysis.montecarlo.study import load_study

    root = Path(__file__).resolve().parents[1] / "results"
    files = sorted(root.rglob("study.toml"))
    assert len(files) > 30
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        studies = {f.relative_to(root).as_posix(): load_study(f) for f in files}
    flat48 = studies["traverse/line_flat-48v/study.toml"].params
    assert (flat48.motor.supply_voltage, flat48.hanging.supply_voltage) == (48.0, 30.0)
    est = studies["realistic/flat/study.toml"].params.estimator
    assert (est.integration, est.accel_process_sigma, est.gyro_meas_sigma) == ("heun", 0.2, 0.0166)


def test_the_capture_criterion_is_the_grippers():
    """The capture criterion and width are the gripper's (``[gripper]``);
    a file or ``--set`` naming them where they were (``scenario``,
    ``traverse.gripper_width``) still sets them, with a warning; the
    gripper's own table wins."""
    from bplir_drake.params import from_dict

    with pytest.warns(FutureWarning, match="scenario.capture_speed is now gripper.capture_speed"):
        p = from_dict({"scenario": {"capture_speed": 2.0, "grip_spacing": 0.34},
                       "traverse": {"gripper_width": 0.05}})
    assert (p.gripper.capture_speed, p.gripper.width, p.scenario.grip_spacing) == (2.0, 0.05, 0.34)
    with pytest.warns(FutureWarning):
        q = from_dict({"scenario": {"capture_distance": 0.05}, "gripper": {"capture_distance": 0.03}})
    assert q.gripper.capture_distance == 0.03
    assert P.BplirParams().gripper == P.GripperParams(capture_distance=0.02, capture_speed=0.5,
                                                      width=0.08)


def test_the_landings_aims_keep_their_share_of_the_capture_band():
    """A gripper with another capture distance keeps the landing's heights
    inside the band as the same share of it (a 30 mm hook: the shot aims
    22.5 mm inside, not the default gripper's 15 mm); a height the file
    gives is kept; an aim below the band is refused, naming the band.  So
    do a planned swing's end depths."""
    from bplir_drake.params import from_dict
    from bplir_drake.params.follow import BAND_FIELDS

    d, hook = P.BplirParams(), from_dict({"gripper": {"capture_distance": 0.03}})
    for block, names in BAND_FIELDS.items():
        assert [getattr(getattr(hook, block), f) for f in names] == pytest.approx(
            [1.5 * getattr(getattr(d, block), f) for f in names], rel=1e-12)
    assert (hook.landing.shoot_height, hook.plan.end_depth) == pytest.approx((-0.0225, 0.0225))
    kept = from_dict({"gripper": {"capture_distance": 0.03}, "landing": {"shoot_height": -0.01}})
    assert (kept.landing.shoot_height, kept.landing.landing_margin) == pytest.approx((-0.01, 0.015))
    with pytest.raises(P.ParameterError, match=r"landing.shoot_height = -0.025 m lies below the "
                       r"capture band; allowed within gripper.capture_distance = 0.02 m"):
        from_dict({"landing": {"shoot_height": -0.025}})


def test_a_plant_tables_friction_follows_its_units():
    """A robot given as a ``[plant]`` table (joints undescribed) has the
    default robot's friction in its own units: Coulomb torques the same
    share of m g L, viscous ones the same at its own rates (x m g L
    sqrt(L/g)), the smoothing rate / sqrt(L/g); what the file gives is
    kept.  The 1.6 kg link 2: m g L x 1.018."""
    from bplir_drake.params import from_dict

    base = P.BplirParams().friction
    small = {"m1": 1.0, "m2": 0.5, "l1": 0.6, "l2": 0.8}
    p = from_dict({"plant": small, "friction": {"fc2": 0.05}})
    L0, m0 = 0.9091 + 1.2451, 3.2287 + 1.5155
    kq, kt = (1.5 * 1.4) / (m0 * L0), math.sqrt(1.4 / L0)
    assert p.friction.fc1 == pytest.approx(base.fc1 * kq, rel=1e-12)
    assert p.friction.fv2 == pytest.approx(base.fv2 * kq * kt, rel=1e-12)
    assert p.friction.b == pytest.approx(base.b / kt, rel=1e-12) and p.friction.fc2 == 0.05
    heavy = from_dict({"plant": {"m2": 1.6}})
    assert heavy.friction.fc2 / base.fc2 == pytest.approx((3.2287 + 1.6) / m0, rel=1e-12)
    assert from_dict({"plant": {"m2": 1.5155}}).friction == base   # the default robot's own


@pytest.mark.filterwarnings("ignore:robot.file")
def test_saved_parameters_and_studies_name_their_robot_file_relative_to_themselves(tmp_path,
                                                                                    monkeypatch):
    """A parameter or study file written elsewhere names the robot's URDF
    relative to itself, so a results directory moved with the files it names
    (or read from another working directory) still loads the same robot."""
    from pathlib import Path

    from bplir_drake.analysis.montecarlo.study import Study, load_study, save_study

    root = Path(__file__).resolve().parents[1]
    robot = P.load_toml(root / "examples" / "commission" / "acromonk_hook.toml")
    assert Path(robot.robot.file).is_absolute()
    out = tmp_path / "results" / "acromonk"
    out.mkdir(parents=True)
    P.save_toml(robot, out / "robot.toml")
    save_study(Study(robot, {}, 3, 5), out / "study.toml")
    for name in ("robot.toml", "study.toml"):
        text = (out / name).read_text()
        assert str(tmp_path) not in text and "acromonk.urdf" in text
    monkeypatch.chdir(tmp_path)   # another working directory
    assert P.load_toml(out / "robot.toml").plant == robot.plant
    assert load_study(out / "study.toml").params.plant == robot.plant
