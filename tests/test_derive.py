"""One derivation: what a manoeuvre runs with is ``params.derive``'s answer
on every path (TOML, Python, the command line), hardware options compose
in the robot's units, and the manoeuvres' rules are stated in them."""
import dataclasses as dc
import json
import math

import pytest

from bplir_drake.cli.main import main
from bplir_drake.params import (BplirParams, GripperParams, Manoeuvre, ParameterError,
                                PlantParams, RETRY_TIME, TRAVERSE_END_SHARE, derive, from_dict,
                                load_toml, parameter_reference, to_dict, with_hardware)

#: a robot of its own: shorter, lighter links and a hook whose capture band is 30 mm
HOOK = {"plant": {"l1": 0.6, "l2": 0.5, "lc1": 0.3, "lc2": 0.28, "m1": 0.9, "m2": 0.7,
                  "I1": 0.03, "I2": 0.02},
        "gripper": {"capture_distance": 0.03}}


def _toml(path):
    lines = []
    for block, table in HOOK.items():
        lines.append(f"[{block}]")
        lines += [f"{k} = {v}" for k, v in table.items()]
    path.write_text("\n".join(lines) + "\n")
    return path


def _python():
    base = BplirParams()
    return dc.replace(base, plant=dc.replace(base.plant, **HOOK["plant"]),
                      gripper=GripperParams(capture_distance=0.03))


def test_a_robot_in_toml_in_python_and_on_the_command_line_derives_the_same(tmp_path, capsys):
    """The same robot read from TOML, built in Python with ``dataclasses.replace``
    (nothing followed yet) and listed by ``bplir params --config`` derives
    identical parameters for the same manoeuvre, held by either gripper, as a
    single swing, a pump, a traversal's swing and a try from hanging."""
    f = _toml(tmp_path / "hook.toml")
    toml, python = load_toml(f), _python()
    assert python.imu.r1 == BplirParams().imu.r1   # Python's: not followed yet
    for m in (Manoeuvre(), Manoeuvre(gripper=2), Manoeuvre(reach="pump"),
              Manoeuvre(gripper=2, context="traverse", spacing=0.81, incline_deg=3.04),
              Manoeuvre(gripper=1, context="retry", raised=1)):
        assert to_dict(derive(toml, m)) == to_dict(derive(python, m))
    assert main(["params", "--config", str(f), "--json"]) == 0
    listed = {(r["block"], r["name"]): r["value"]
              for r in json.loads(capsys.readouterr().out)["parameters"]}
    derived = derive(python)
    for (block, name), value in listed.items():
        want = getattr(getattr(derived, block), name)
        assert value == (list(want) if isinstance(want, tuple) else want), (block, name)
    # the robot's units, not the default robot's SI numbers
    base = BplirParams()
    assert derived.imu.r1 == pytest.approx(base.imu.r1 * 0.6 / base.plant.l1, rel=1e-12)
    assert derived.landing.shoot_height == pytest.approx(1.5 * -0.015, rel=1e-12)
    assert derive(derived) == derived   # following is idempotent


def test_hardware_options_compose_with_a_config_in_the_robots_units(tmp_path, capsys):
    """``--config hook.toml --hardware line-sensor`` on a robot whose
    capture band is 30 mm aims the landing 1.5 times the default robot's
    line-sensor aim (27 mm of 30, not 18), holds it for the robot's own
    time unit, keeps the sensor's 0.2 m range, and the options' order does
    not matter."""
    f = _toml(tmp_path / "hook.toml")
    assert main(["params", "landing", "--config", str(f), "--hardware", "line-sensor",
                 "--json"]) == 0
    rows = {r["name"]: r["value"] for r in json.loads(capsys.readouterr().out)["parameters"]}
    hook, base = load_toml(f), BplirParams()
    kt = math.sqrt((0.6 + 0.5) / (base.plant.l1 + base.plant.l2))
    assert rows["shoot_height"] == pytest.approx(-0.018 * 1.5, rel=1e-12)
    assert rows["shoot_min_time"] == pytest.approx(max(0.03 * kt, 0.02), rel=1e-12)
    assert rows["shoot_lift_min_time"] == pytest.approx(0.05 * kt, rel=1e-12)
    both = with_hardware(hook, "line-sensor", "48v")
    assert both == with_hardware(hook, "48v", "line-sensor")
    assert both.line_sensor.range == 0.2 and both.motor.supply_voltage == 48.0
    assert derive(hook, hardware=("line-sensor",)) == with_hardware(hook, "line-sensor")


def test_a_manoeuvres_rules_are_in_the_robots_units():
    """A traversal's swing rests 0.65 of the capture band below the line
    (13 mm of the default 20 mm, 19.5 of the hook's 30); a try from hanging
    has 12.8 sqrt(L/g) to arrive (6.0 s on the default robot) and counts
    its raised aims; a pump has 20 sqrt(L/g)."""
    base, hook = BplirParams(), derive(_python())
    step = Manoeuvre(context="traverse")
    assert TRAVERSE_END_SHARE == 0.65 and RETRY_TIME == 12.8
    assert derive(base, step).plan.end_depth == 0.013
    assert derive(hook, step).plan.end_depth == pytest.approx(0.0195)
    t0 = math.sqrt((0.6 + 0.5) / 9.81)
    assert derive(base, Manoeuvre(context="retry")).scenario.max_time == 6.0
    assert derive(hook, Manoeuvre(context="retry")).scenario.max_time == round(12.8 * t0, 2)
    assert derive(hook, Manoeuvre(reach="pump")).scenario.max_time == round(20 * t0, 2)
    raised = derive(base, Manoeuvre(context="retry", raised=2)).landing.landing_bias
    assert raised == pytest.approx(2 * base.traverse.retry_aim_raise)
    held = derive(base, Manoeuvre(gripper=2))
    assert (held.plant.l1, held.plant.l2) == (base.plant.l2, base.plant.l1)


def test_a_manoeuvre_out_of_range_is_one_line_and_old_fields_are_retired():
    """A manoeuvre names its allowed values; the fields the manoeuvres'
    rules replaced load silently at the default robot's values and with a
    warning naming the rule otherwise; fewer than 227 parameters remain."""
    with pytest.raises(ParameterError, match="manoeuvre gripper = 3; allowed: 1, 2"):
        Manoeuvre(gripper=3)
    with pytest.raises(ParameterError, match="manoeuvre context = 'rest'; allowed: single"):
        Manoeuvre(context="rest")
    assert from_dict({"traverse": {"plan_end_depth": 0.013, "retry_max_time": 6.0}}) \
        == BplirParams()
    with pytest.warns(FutureWarning, match=r"traverse.retry_max_time = 8.0 \(now the rule "
                                           r"derive.RETRY_TIME sqrt\(L/g\)\)"):
        from_dict({"traverse": {"retry_max_time": 8.0}})
    assert len(parameter_reference()) == 226 < 227
    assert isinstance(BplirParams().plant, PlantParams)


def test_the_landing_law_is_chosen_by_its_name(tmp_path):
    """``landing.landing_law = "none"`` tracks the plan to its end and
    ``"reach"`` picks the terminal reach; a file written when
    ``landing_lead = 0`` switched the landing off reads as the law by name,
    with one warning, and the lead can no longer be 0."""
    import warnings

    from bplir_drake.diagrams.swing_controller import DelayCompensation, plan_tracker
    from bplir_drake.diagrams.swing_setup import swing_geometry
    from bplir_drake.params import preset
    from bplir_drake.planning.solve import tracking_plan
    from bplir_drake.systems.landing import ApexShot, Landing, Reach

    p = preset()
    old = tmp_path / "old.toml"
    old.write_text("[landing]\nlanding_lead = 0.0\n")
    with pytest.warns(FutureWarning, match=r"landing.landing_lead = 0 \(now "
                                           r"landing.landing_law = 'none'\)"):
        assert load_toml(old).landing == dc.replace(p.landing, landing_law="none")
    old.write_text("[landing]\nlanding_lead = 0.0\nreach_speed = 0.2\n")
    with pytest.warns(FutureWarning, match="landing_law = 'reach'"):
        assert load_toml(old).landing.landing_law == "reach"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert load_toml(_write(tmp_path / "new.toml", "[landing]\nlanding_law = 'none'\n")
                         ).landing.landing_law == "none"
    with pytest.raises(ParameterError, match="landing.landing_lead"):
        dc.replace(p.landing, landing_lead=0.0)
    gains, geometry = tracking_plan(p)[1], swing_geometry(p)[2]
    laws = {}
    for law in ("shoot", "aim", "reach", "none"):
        q = p.with_(landing=dc.replace(p.landing, landing_law=law))
        laws[law] = plan_tracker(q, DelayCompensation(None, 0, ()), geometry, gains).reach
    assert isinstance(laws["shoot"], ApexShot) and isinstance(laws["aim"], Landing)
    assert isinstance(laws["reach"], Reach) and laws["none"] is None


def _write(path, text):
    path.write_text(text)
    return path


def test_the_line_sensor_is_fitted_by_name(tmp_path):
    """``line_sensor.fitted`` says whether the jaws carry the sensor; a file
    from when ``range = 0`` meant none reads the same silently, and one
    whose ``range > 0`` fitted it reads as fitted, with one warning."""
    import warnings

    from bplir_drake.params import load_toml, preset

    p = preset()
    assert not p.line_sensor.fitted and p.line_sensor.range == 0.2
    old = _write(tmp_path / "old.toml", "[line_sensor]\nrange = 0.0\nsigma = 0.002\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert load_toml(old).line_sensor == dc.replace(p.line_sensor, sigma=0.002)
    _write(old, "[line_sensor]\nrange = 0.3\n")
    with pytest.warns(FutureWarning, match=r"line_sensor.range = 0.3 \(now line_sensor.fitted"):
        sensor = load_toml(old).line_sensor
    assert sensor.fitted and sensor.range == 0.3
    with pytest.raises(ParameterError, match="line_sensor.range = 0 is out of range"):
        dc.replace(p.line_sensor, range=0.0)


def test_the_lift_law_is_named_and_traverse_landing_is_retired(tmp_path):
    """``landing.lift_law`` names the law ``auto`` uses where the elbow
    lifts the gripper; a file from when ``shoot_lift_min_time > 0`` chose
    the shot reads as ``lift_law = "shoot"`` with one warning (0: the aim
    law, silently), and ``traverse.landing = false`` reads as the law
    ``none``."""
    import warnings

    from bplir_drake.params import load_toml, preset

    p = preset()
    assert (p.landing.lift_law, p.landing.shoot_lift_min_time) == ("aim", 0.05)
    old = _write(tmp_path / "old.toml", "[landing]\nshoot_lift_min_time = 0.0\n")
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert load_toml(old) == p
    _write(old, "[landing]\nshoot_lift_min_time = 0.06\n")
    with pytest.warns(FutureWarning, match="shoot_lift_min_time = 0.06 without landing.lift_law"):
        landing = load_toml(old).landing
    assert (landing.lift_law, landing.shoot_lift_min_time) == ("shoot", 0.06)
    _write(old, "[traverse]\nlanding = false\n")
    with pytest.warns(FutureWarning, match=r"traverse.landing = false \(now landing.landing_law"):
        assert load_toml(old).landing.landing_law == "none"
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert load_toml(_write(old, "[traverse]\nlanding = true\n")) == p


def test_a_switch_is_a_named_choice_beside_its_number(tmp_path):
    """A number whose 0 used to turn something off (a threshold, a cap, a
    share, a sentinel) holds the choice's name instead: every such field
    accepts its number or its name, reads a 0 (the former spelling) as the
    name, round-trips through TOML, and its allowed range names it."""
    from dataclasses import fields

    from bplir_drake.params import BLOCKS, load_toml, preset, save_toml

    p = preset()
    offs = {(b, f.name): f.metadata["off"] for b, cls in BLOCKS.items()
            if b != "robot" and not b.startswith("true_") for f in fields(cls)
            if f.metadata.get("off")}
    assert offs == {("estimator", "inflate_nis"): "never", ("plan", "warm_spacing"): "none",
                    ("hanging", "supply_voltage"): "motor", ("hanging", "i2t_share"): "none",
                    ("landing", "reach_tangent"): "never",
                    ("landing", "shoot_give_up_rate"): "never",
                    ("landing", "shoot_brake_ratio"): "never",
                    ("landing", "shoot_rate_cap"): "none",
                    ("traverse", "shoot_brake_ratio"): "landing"}
    for (block, name), off in offs.items():
        table = getattr(p, block)
        assert getattr(dc.replace(table, **{name: 0.0}), name) == off
        assert getattr(from_dict({block: {name: 0}}), block) == dc.replace(table, **{name: off})
        with pytest.raises(ParameterError, match=rf"{block}.{name} = 'off' .*or '{off}'"):
            dc.replace(table, **{name: "off"})
    q = p.with_(landing=dc.replace(p.landing, shoot_rate_cap="none"),
                hanging=dc.replace(p.hanging, i2t_share=0.3))
    save_toml(q, tmp_path / "q.toml")
    assert load_toml(tmp_path / "q.toml") == q
    ref = {(r["block"], r["name"]): r["range"] for r in parameter_reference()}
    assert ref["landing", "shoot_rate_cap"] == "(0, 5] or 'none'"   # the unit in its own column


def test_a_robot_names_its_manoeuvre_for_each_gripper(tmp_path):
    """``scenario.manoeuvre = "swing,pump"`` (what commissioning chose for
    the default robot at 30 V): held by gripper 1 it swings, by gripper 2
    it pumps (20 sqrt(L/g) to arrive, 9.37 s), a try from hanging is a swing
    from hanging either way; a traversal's pump comes to rest where the
    robot's own pump does (1.5 of the band's 2 cm, not the traversal swing's
    1.3), so its plans are the library commissioning verified (the same
    key).  A third entry or an unknown one is refused, naming the allowed."""
    from bplir_drake.planning.library import robot_library_key

    base = BplirParams()
    robot = base.with_(scenario=dc.replace(base.scenario, manoeuvre="swing,pump"))
    assert from_dict({"scenario": {"manoeuvre": "swing,pump"}}) == robot
    first, second = derive(robot, Manoeuvre(gripper=1)), derive(robot, Manoeuvre(gripper=2))
    assert (first.scenario.manoeuvre, first.scenario.max_time) == ("swing", 3.0)
    assert (second.scenario.manoeuvre, second.scenario.max_time) == ("pump", 9.37)
    assert derive(base, Manoeuvre(gripper=1)) == first
    for g in (1, 2):
        tried = derive(robot, Manoeuvre(gripper=g, context="retry"))
        assert (tried.scenario.manoeuvre, tried.scenario.start) == ("swing", "hanging")
    step = derive(robot, Manoeuvre(gripper=2, spacing=1.2, incline_deg=0.0, context="traverse"))
    assert step.plan.end_depth == second.plan.end_depth == 0.015
    assert derive(robot, Manoeuvre(gripper=1, context="traverse")).plan.end_depth == 0.013
    assert robot_library_key(step) == robot_library_key(derive(base, Manoeuvre(gripper=2,
                                                                              reach="pump")))
    for bad in ("swing,pump,swing", "hop", "swing,hop"):
        with pytest.raises(ParameterError, match="allowed: swing, pump, or one per gripper"):
            from_dict({"scenario": {"manoeuvre": bad}})
    with pytest.raises(ParameterError, match="starts on the line"):
        derive(robot, Manoeuvre(gripper=2, start="hanging", reach="pump"))
