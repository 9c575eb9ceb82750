"""Robots from their URDF: the BPLIR's shipped description is the hand-built
plant, an off-axis robot's description is the parsed plant's dynamics, and
a config naming a file gets the links, the spacings and the IMU radii of
that robot."""
import math

import numpy as np
import pytest

from bplir_drake.params import BplirParams, ParameterError, PlantParams, RobotFileParams
from bplir_drake.params import load_toml
from bplir_drake.params.robot_file import describe_robot
from bplir_drake.systems.plant import description_residual

from test_hardening import assert_one_line_error, bplir

#: a small robot in the layout of a CAD export: joint axes along x, the
#: links along the hook's +y turned down by the base joint's rpy, the elbow
#: 20 mm off link 1's y axis, a hook welded to link 2's end and a base
#: welded to the world (which does not move)
OFF_AXIS_URDF = """<?xml version="1.0"?>
<robot name="small">
  <link name="world"/>
  <link name="base"><inertial><origin xyz="0 0.5 0"/><mass value="5"/>
    <inertia ixx="1" ixy="0" ixz="0" iyy="1" iyz="0" izz="1"/></inertial></link>
  <joint name="weld" type="fixed"><parent link="world"/><child link="base"/></joint>
  <link name="hook1"><inertial><origin xyz="-0.007 0.23 -0.02"/><mass value="1.04"/>
    <inertia ixx="0.0017" ixy="-1e-5" ixz="0" iyy="0.0007" iyz="-4e-6" izz="0.0012"/></inertial></link>
  <joint name="pivot" type="revolute"><parent link="base"/><child link="hook1"/>
    <origin xyz="0 0 0" rpy="-1.5708 0 0"/><axis xyz="1 0 0"/>
    <limit lower="-3.14" upper="3.14" effort="16" velocity="40"/></joint>
  <link name="arm2"><inertial><origin xyz="0.0004 0.09 0.00003"/><mass value="0.5"/>
    <inertia ixx="0.001" ixy="0" ixz="0" iyy="0.0004" iyz="0" izz="0.0006"/></inertial></link>
  <joint name="elbow" type="revolute"><parent link="hook1"/><child link="arm2"/>
    <origin xyz="0.022 0.314 -0.02"/><axis xyz="AXIS"/>
    <limit lower="-3.14" upper="3.14" effort="16" velocity="40"/></joint>
  <link name="hook2"><inertial><origin xyz="0.02 -0.035 0.027"/><mass value="0.1"/>
    <inertia ixx="0.00014" ixy="0" ixz="0" iyy="0.00004" iyz="0" izz="0.00012"/></inertial></link>
  <joint name="hook2_weld" type="fixed"><parent link="arm2"/><child link="hook2"/>
    <origin xyz="-0.022 0.314 -0.02"/></joint>
</robot>
"""


def _write(tmp_path, axis="1 0 0"):
    path = tmp_path / "small.urdf"
    path.write_text(OFF_AXIS_URDF.replace("AXIS", axis))
    return path


def _small(path):
    return RobotFileParams(file=str(path), pivot_joint="pivot", elbow_joint="elbow",
                           free_gripper="hook2")


def test_the_shipped_bplir_description_is_the_hand_built_plant():
    d = describe_robot(RobotFileParams(file="bplir"))
    assert d.plant == PlantParams()
    assert d.offset == (0.0, 0.0) and d.sign2 == 1.0
    assert description_residual(d) < 1e-12


@pytest.mark.parametrize("axis, sign", [("1 0 0", 1.0), ("-1 0 0", -1.0)])
def test_an_off_axis_description_is_the_parsed_plants_dynamics(tmp_path, axis, sign):
    """Lengths joint to joint, the welded hook counted with link 2, the base
    ignored, the elbow's 20 mm offset turning the angles' zero, and the
    closed form of what was read equal to the parsed plant's M, C v and g
    at 50 states in the file's joint coordinates (an elbow turning the
    other way included)."""
    d = describe_robot(_small(_write(tmp_path, axis)))
    p = d.plant
    assert p.l1 == pytest.approx(math.hypot(0.314, 0.02), abs=1e-12)
    assert p.l2 == pytest.approx(math.hypot(0.314, 0.02), abs=1e-12)
    assert p.m1 == pytest.approx(1.04) and p.m2 == pytest.approx(0.6)
    # the elbow 20 mm towards the file's -z (the package's -x when hanging),
    # and the base joint's rpy of -1.5708 tilting the reference pose by its
    # 3.7 urad from -pi/2
    tilt = 1.5708 - math.pi / 2
    assert d.offset[0] == pytest.approx(-math.atan2(0.02, 0.314) - tilt, abs=1e-12)
    # link 1's centre of mass (-0.02, -0.23) in the plane against its axis (-0.02, -0.314)
    assert p.lc1 == pytest.approx((0.02 * 0.02 + 0.23 * 0.314) / p.l1, abs=1e-11)
    assert p.oc1 == pytest.approx((-0.02 * 0.314 + 0.23 * 0.02) / p.l1, abs=1e-11)
    assert d.sign2 == sign
    assert description_residual(d) < 1e-9
    # the file's states and the package's map back and forth
    x = np.array([0.3, -1.1, 2.0, -0.5])
    assert np.allclose(d.to_file_state(d.from_file_state(x)), x, atol=1e-15)


def test_a_config_naming_a_file_gets_that_robot(tmp_path):
    """A relative path from the config's directory; [plant] fields given
    next to the file override it; the IMU radii, grip spacings and landing
    depths follow the smaller robot's links unless given."""
    _write(tmp_path)
    cfg = tmp_path / "small.toml"
    cfg.write_text('[robot]\nfile = "small.urdf"\npivot_joint = "pivot"\nelbow_joint = "elbow"\n'
                   'free_gripper = "hook2"\n\n[plant]\nI1 = 0.002\n\n[imu]\nr2 = 0.2\n')
    with pytest.warns(UserWarning, match="describes no fv1, fv2, fc1, fc2"):
        p = load_toml(cfg)
    d = describe_robot(p.robot)
    assert p.plant.I1 == 0.002 and p.plant.m1 == d.plant.m1 and p.plant.oc2 == d.plant.oc2
    base = BplirParams()
    k = (p.plant.l1 + p.plant.l2) / (base.plant.l1 + base.plant.l2)
    assert p.scenario.grip_spacing == pytest.approx(1.2 * k, abs=1e-3)
    assert p.traverse.spacing_max == pytest.approx(1.5 * k, abs=1e-3)
    assert p.landing.shoot_depth == pytest.approx(base.landing.shoot_depth * k, abs=1e-3)
    assert p.imu.r1 == pytest.approx(0.5 * p.plant.l1 / base.plant.l1) and p.imu.r2 == 0.2


def test_a_bad_description_is_one_line(tmp_path):
    path = _write(tmp_path)
    rc, _, err = bplir("model", "--set", f"robot.file={tmp_path / 'none.urdf'}")
    assert_one_line_error(rc, err, "robot.file", "no such file")
    cfg = tmp_path / "bad.toml"
    cfg.write_text(f'[robot]\nfile = "{path}"\npivot_joint = "hinge"\n')
    rc, _, err = bplir("model", "--config", cfg)
    assert_one_line_error(rc, err, "robot.pivot_joint = 'hinge'", "pivot", "elbow")
    with pytest.raises(ParameterError, match="allowed: a .urdf or .sdf"):
        describe_robot(RobotFileParams(file=str(tmp_path / "small.toml")))


def test_the_bplir_from_its_urdf_swings_as_the_hand_built_one():
    """The default swing (seed 0, EKF in the loop) of the robot read from
    the shipped URDF and of the hand-built one: every reported number within
    1e-9."""
    from bplir_drake.analysis.swing.swing_runner import SwingRunner
    from bplir_drake.params import from_dict

    runner = SwingRunner()
    hand = runner.run(BplirParams(), seed=0).summary
    urdf = runner.run(from_dict({"robot": {"file": "bplir"}}), seed=0).summary
    assert hand["success"] and urdf["success"]
    numbers = [k for k, v in hand.items() if isinstance(v, float)]
    assert len(numbers) > 5
    for k in numbers:
        assert urdf[k] == pytest.approx(hand[k], abs=1e-9, nan_ok=True), k


@pytest.mark.slow
def test_a_short_link_robot_runs_every_command(tmp_path, monkeypatch):
    """AcroMonk's links (0.31 m, examples/acromonk.toml) through model, plan,
    swing and calibrate: no BPLIR default in the way (the IMU radii, grip
    spacing, landing depths follow its links, the LQR weights, probe and
    landing times its scales m g L, sqrt(L/g)).  The calibration fits a log
    (controlled from the true state: the BPLIR's filter tuning diverges on
    several of AcroMonk's seeds) from a friction and an inertia set wrong
    and recovers the simulated robot's (its friction drawn within the
    scenario's uncertainty)."""
    import csv
    import json

    from pathlib import Path

    monkeypatch.setenv("BPLIR_CACHE_DIR", str(tmp_path / "cache"))
    cfg = Path(__file__).resolve().parents[1] / "examples" / "acromonk.toml"
    rc, out, err = bplir("model", "--config", cfg, "--out", tmp_path / "model", "--json")
    assert rc == 0, err
    model = json.loads(out)   # the dissertation's Table 4.1 and the BPLIR's voltage are not its
    assert "friction_rmse_published" not in model
    assert {k: model["envelope"][k] for k in ("voltage_envelope", "current_limit_torque_Nm")} \
        == {"voltage_envelope": False, "current_limit_torque_Nm": 3.0}
    rc, out, err = bplir("plan", "--config", cfg, "--out", tmp_path / "plan", "--json")
    plan = json.loads(out)
    assert plan["peak_torque_Nm"] <= 3.0 + 1e-6 and plan["torque_limit_Nm"] == 3.0
    rc, out, err = bplir("swing", "--config", cfg, "--true-state", "--out", tmp_path / "swing",
                         "--json")
    swing = json.loads(out)
    assert rc in (0, 1) and swing["peak_torque_Nm"] <= 3.0 + 1e-9, err
    with open(tmp_path / "swing" / "swing_log.csv") as f:
        rows = list(csv.DictReader(f))
    with open(tmp_path / "log.csv", "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["t", "q1", "q2", "tau", "q1d", "q2d"])
        for r in rows:
            w.writerow([r["t"], r["q1"], r["q2"], r["torque"], r["q1d"], r["q2d"]])
    rc, out, err = bplir("calibrate", tmp_path / "log.csv", "--config", cfg, "--out",
                         tmp_path / "cal", "--set", "friction.fv2=0.03", "--set", "plant.I1=0.003",
                         "--fit", "fv1,fv2,I1", "--json")
    assert rc == 0, err
    cal = json.loads(out)
    true = swing["true_friction"]
    assert cal["fitted"]["fv1"] == pytest.approx(true["fv1"], rel=0.03)
    assert cal["fitted"]["fv2"] == pytest.approx(true["fv2"], rel=0.03)
    # the inertia about the centre of mass is 3 % of link 1's inertia about the
    # pivot: the log's 5 ms torque samples leave it within 15 %
    assert cal["fitted"]["I1"] == pytest.approx(0.0017085, rel=0.15)
    assert cal["rmse_after_rad"] < min(0.01, cal["rmse_before_rad"] / 20)


def test_an_sdformat_description_is_read_as_the_urdf_is(tmp_path):
    """The BPLIR written in SDFormat (the free gripper a frame, not a link)
    reads as the same plant as its URDF and the hand-built one."""
    path = tmp_path / "bplir.sdf"
    path.write_text(SDF)
    d = describe_robot(RobotFileParams(file=str(path)))
    assert d.plant == PlantParams() and d.offset == (0.0, 0.0)
    assert description_residual(d) < 1e-12


SDF = """<?xml version="1.0"?>
<sdf version="1.7">
  <model name="bplir_sdf">
    <link name="link1">
      <inertial>
        <pose>0 0 -0.2167 0 0 0</pose>
        <mass>3.2287</mass>
        <inertia><ixx>0.1539</ixx><iyy>0.1539</iyy><izz>1.539e-05</izz>
          <ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia>
      </inertial>
    </link>
    <link name="link2">
      <pose>0 0 -0.9091 0 0 0</pose>
      <inertial>
        <pose>0 0 -0.5459 0 0 0</pose>
        <mass>1.5155</mass>
        <inertia><ixx>0.2191</ixx><iyy>0.2191</iyy><izz>2.191e-05</izz>
          <ixy>0</ixy><ixz>0</ixz><iyz>0</iyz></inertia>
      </inertial>
    </link>
    <frame name="free_gripper" attached_to="link2"><pose>0 0 -1.2451 0 0 0</pose></frame>
    <joint name="gripper_joint" type="revolute">
      <parent>world</parent><child>link1</child>
      <axis><xyz>0 -1 0</xyz><limit><lower>-1e16</lower><upper>1e16</upper></limit></axis>
    </joint>
    <joint name="elbow_joint" type="revolute">
      <parent>link1</parent><child>link2</child>
      <axis><xyz>0 -1 0</xyz><limit><lower>-1e16</lower><upper>1e16</upper></limit></axis>
    </joint>
  </model>
</sdf>
"""


def test_a_files_joint_damping_is_the_viscous_friction_and_a_rotor_inertia_is_refused(
        tmp_path):
    """The elbow's <dynamics damping> of the file becomes friction.fv2 unless
    the config gives fv2; what neither gives is 0 with a warning naming it,
    never the default robot's; a motor's reflected rotor inertia (which the
    two links cannot carry) is refused with one line."""
    from bplir_drake.params import from_dict

    text = OFF_AXIS_URDF.replace("AXIS", "1 0 0").replace(
        '<origin xyz="0.022 0.314 -0.02"/><axis xyz="1 0 0"/>',
        '<origin xyz="0.022 0.314 -0.02"/><axis xyz="1 0 0"/><dynamics damping="0.05"/>')
    path = tmp_path / "damped.urdf"
    path.write_text(text)
    robot = {"file": str(path), "pivot_joint": "pivot", "elbow_joint": "elbow",
             "free_gripper": "hook2"}
    with pytest.warns(UserWarning, match="describes no fv1, fc1, fc2: taken as 0"):
        p = from_dict({"robot": robot})
    assert (p.friction.fv2, p.friction.fv1, p.friction.fc1, p.friction.fc2) == (0.05, 0, 0, 0)
    assert BplirParams().friction.fc2 > 0.5   # the default robot's, not carried over
    given = {"fv1": 0.02, "fv2": 0.07, "fc1": 0.0, "fc2": 0.1}
    assert from_dict({"robot": robot, "friction": given}).friction.fv2 == 0.07
    geared = text.replace("</robot>", """
  <transmission name="t"><type>transmission_interface/SimpleTransmission</type>
    <joint name="elbow"><hardwareInterface>EffortJointInterface</hardwareInterface></joint>
    <actuator name="motor"><drake:rotor_inertia value="0.001"/>
      <drake:gear_ratio value="6.0"/></actuator></transmission>
</robot>""").replace('<robot name="small">',
                     '<robot name="small" xmlns:drake="http://drake.mit.edu">')
    path.write_text(geared)
    with pytest.raises(ParameterError, match="reflected rotor inertia .0.036 kg m.2."):
        describe_robot(RobotFileParams(**robot))
