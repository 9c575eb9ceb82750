"""The Gymnasium environment (``bplir_drake.gym``): Gymnasium's own checker,
episodes reproducible from the seed, the reward and termination it states,
and a policy from it run as a controller plug-in."""
import math
import warnings

import numpy as np
import pytest

gym = pytest.importorskip("gymnasium")

from bplir_drake.gym import ENV_ID, TERMINAL_REWARD, BrachiationEnv  # noqa: E402
from bplir_drake.gym.env import observation_bounds  # noqa: E402

POLICY = '''import numpy as np
from bplir_drake.gym import as_controller

def pump(obs):
    """Elbow with link 1's rate, held back by its own angle and rate."""
    return np.array([0.6 * np.tanh(3.0 * obs[2]) - 0.3 * obs[1] - 0.05 * obs[3]])

make = as_controller(pump)
'''


def pump(obs):
    return np.array([0.6 * np.tanh(3.0 * obs[2]) - 0.3 * obs[1] - 0.05 * obs[3]],
                    dtype=np.float32)


def test_gymnasiums_checker_passes_without_a_warning():
    """``check_env`` on the registered environment (its render modes too)."""
    from gymnasium.utils.env_checker import check_env

    env = gym.make(ENV_ID)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    assert [str(w.message) for w in caught] == []
    env.close()


def test_a_hundred_seeds_give_the_same_episodes_twice():
    """100 seeds, each reset and stepped 25 ticks twice with the same
    actions: identical observations and rewards; different seeds draw
    different robots."""
    env = BrachiationEnv()
    actions = np.sin(np.arange(25) / 4.0).astype(np.float32).reshape(-1, 1)

    def episode(seed):
        obs, info = env.reset(seed=seed)
        out = [obs]
        for a in actions:
            obs, r, *_ = env.step(a)
            out.append(np.r_[obs, r])
        return np.concatenate(out), info["sample_seed"]

    roots = set()
    for seed in range(100):
        a, root = episode(seed)
        b, again = episode(seed)
        assert root == again and np.array_equal(a, b), seed
        roots.add(root)
    assert len(roots) == 100
    env.close()


def test_the_reward_is_the_distance_to_the_grip_and_the_outcome():
    """Zero torque: the robot hangs, the episode is truncated at the
    scenario's max_time (3 s, 300 ticks) as a timeout; each step's reward is
    minus the gripper's distance to the grip over the reach, times T over
    max_time; the observation keeps within its bounds."""
    env = BrachiationEnv()
    obs, info = env.reset(seed=5)
    p = env.params
    L, D = p.simulated_plant.l1 + p.simulated_plant.l2, p.scenario.grip_spacing
    steps, total = 0, 0.0
    while True:
        obs, r, terminated, truncated, info = env.step(np.zeros(1, dtype=np.float32))
        steps += 1
        total += r
        assert r == pytest.approx(-(info["distance_m"] / L) * (0.01 / 3.0), rel=1e-12)
        assert env.observation_space.contains(obs)
        if terminated or truncated:
            break
    assert (steps, terminated, truncated, info["outcome"]) == (300, False, True, "timeout")
    # hanging near the start, the gripper is about 2 D from the grip: the
    # episode sums to about -2 D / L
    assert total == pytest.approx(-2 * D / L, rel=0.1)
    assert TERMINAL_REWARD == {"captured": 1.0, "crash": -1.0, "fault": -1.0, "timeout": 0.0}


def test_a_policy_is_the_same_swing_as_a_controller_plugin(tmp_path):
    """The environment's episode with a scripted policy and ``bplir``'s swing
    of the same drawn robot with the policy as a plug-in
    (:func:`as_controller`): the same outcome and state to 1e-6 after 3 s."""
    from bplir_drake.analysis.swing.swing_runner import run_swing

    plugin = tmp_path / "policy.py"
    plugin.write_text(POLICY)
    env = BrachiationEnv()
    for seed in (0, 1):
        obs, info = env.reset(seed=seed)
        while True:
            obs, r, terminated, truncated, last = env.step(pump(obs))
            if terminated or truncated:
                break
        swing = run_swing(env.params.with_controller(f"{plugin}:make"), seed=info["swing_seed"])
        assert swing.summary["outcome"] == last["outcome"]
        assert np.max(np.abs(swing.logs["state"].data[-1] - env.true_state())) < 1e-6
    env.close()


def test_a_policy_from_the_environment_is_scored_by_bplir_benchmark(tmp_path, capsys):
    """``bplir benchmark --quick --controllers policy.py:make``: the scripted
    policy is scored on every case (30 swings); it does not swing to the
    line, so it passes none."""
    import json

    from bplir_drake.cli import main

    plugin = tmp_path / "policy.py"
    plugin.write_text(POLICY)
    spec = f"{plugin}:make"
    assert main(["benchmark", "--quick", "--controllers", spec, "--json",
                 "--out", str(tmp_path / "bench")]) == 0
    scores = json.loads(capsys.readouterr().out)["scores"][spec]
    assert scores["swings"] == 30 and scores["overall"] == 0.0
    assert len(scores["categories"]) == 10 and scores["categories"]["knockdown"] == 0.0


def test_the_imu_observation_and_the_bounds():
    """``observation = "imu"``: the six IMU signals; over 60 ticks of the
    same episode the gyros read link 1's rate and link 2's absolute rate
    as the estimate has them (``q1'``, ``q1' + q2'``; within 0.15 rad/s:
    noise, biases); the bounds are two turns, ten times the elbow's
    no-load rate (14.4 rad/s at 30 V) and ten g."""
    env, est = BrachiationEnv(observation="imu"), BrachiationEnv()
    obs, _ = env.reset(seed=2)
    x, _ = est.reset(seed=2)
    assert obs.shape == (6,) and x.shape == (4,)
    for k in range(60):
        a = np.array([0.8 * math.sin(k / 6.0)], dtype=np.float32)
        (obs, *_), (x, *_) = env.step(a), est.step(a)
        assert abs(obs[0] - x[2]) < 0.15 and abs(obs[1] - (x[2] + x[3])) < 0.15, k
    assert np.max(np.abs(x[2:])) > 1.0   # it moved
    p = env.params
    high = observation_bounds(p, "estimate")
    free = p.motor.max_voltage / (p.motor.back_emf_constant * p.motor.gear_ratio)
    assert free == pytest.approx(14.4, abs=0.1)
    assert high.tolist() == pytest.approx([4 * math.pi] * 2 + [10 * free] * 2)
    assert observation_bounds(p, "imu").tolist() == pytest.approx([10 * free] * 2 + [98.1] * 4)
    with pytest.raises(ValueError, match="allowed: estimate, imu"):
        BrachiationEnv(observation="camera")
    env.close()


def test_the_rgb_picture_shows_the_robot(tmp_path):
    """``render()`` in ``rgb_array`` mode: an RGB image with the links drawn
    (the link colour's pixels), saved for a look."""
    from PIL import Image

    env = BrachiationEnv(render_mode="rgb_array")
    env.reset(seed=1)
    for _ in range(30):
        env.step(np.ones(1, dtype=np.float32))
    img = env.render()
    assert img.shape == (360, 480, 3) and img.dtype == np.uint8
    blue = np.all(np.abs(img.astype(int) - (31, 119, 180)) < 30, axis=-1)   # matplotlib's C0
    assert blue.sum() > 500
    Image.fromarray(img).save(tmp_path / "frame.png")
    env.close()


def test_the_gym_page_runs(tmp_path, monkeypatch, capsys):
    """docs/gym.md's first code block runs as written and prints the
    outcome and time it says (a constant fifth of the torque limit crashes
    the gripper into the line at 1.08 s)."""
    import re
    from pathlib import Path

    page = Path(__file__).resolve().parents[1] / "docs" / "gym.md"
    code = re.findall(r"```python\n(.*?)```", page.read_text(), re.S)[0]
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "gym.md block 1", "exec"), {"__name__": "__main__"})
    assert capsys.readouterr().out.strip() == "crash 1.08"
