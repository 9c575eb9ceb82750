"""Benchmark: the learning environment's steps per second, measured in one
run: one environment in this process, then two in processes of their
own, then two in lockstep (Gymnasium's ``AsyncVectorEnv``, one process
each: every step waits for both), each stepping the same
scripted policy through whole episodes (resets included), and the ratios
to one.  A step is one controller tick (10 ms of the swing).

Run: python benchmarks/bench_gym.py [--steps N] [--json PATH]
(prints figures, not a test).
"""
import argparse
import json
import time

import numpy as np


def policy(obs):
    """Elbow with link 1's rate (the tests' scripted policy)."""
    return np.clip(0.6 * np.tanh(3.0 * obs[..., 2:3]) - 0.3 * obs[..., 1:2]
                   - 0.05 * obs[..., 3:4], -1, 1).astype(np.float32)


def make():
    from bplir_drake.gym import BrachiationEnv

    return BrachiationEnv()


def one(steps: int) -> float:
    """Steps per second of one environment."""
    env = make()
    obs, _ = env.reset(seed=0)
    env.step(policy(obs))   # the compiled kernels loaded before the clock starts
    t0, episode = time.perf_counter(), 1
    obs, _ = env.reset(seed=episode)
    for _ in range(steps):
        obs, _, terminated, truncated, _ = env.step(policy(obs))
        if terminated or truncated:
            episode += 1
            obs, _ = env.reset(seed=episode)
    return steps / (time.perf_counter() - t0)


def vector(steps: int, n: int = 2) -> float:
    """Steps per second of ``n`` environments in ``n`` processes (all
    steps counted)."""
    import gymnasium as gym

    envs = gym.vector.AsyncVectorEnv([make] * n, context="fork")
    obs, _ = envs.reset(seed=0)
    envs.step(policy(obs))
    t0 = time.perf_counter()
    for _ in range(steps // n):
        obs, *_ = envs.step(policy(obs))   # a finished episode resets itself
    rate = (steps // n) * n / (time.perf_counter() - t0)
    envs.close()
    return rate


def independent(steps: int, n: int = 2) -> float:
    """Steps per second of ``n`` environments each in a process of its own,
    not in lockstep (the sum of their rates)."""
    import multiprocessing

    with multiprocessing.get_context("fork").Pool(n) as pool:
        return sum(pool.map(one, [steps // n] * n))


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--steps", type=int, default=6000)
    ap.add_argument("--json", help="also write the figures here")
    args = ap.parse_args()
    single = one(args.steps)
    apart = independent(args.steps)
    double = vector(args.steps)
    print(f"one environment: {single:.0f} steps/s ({single * 0.01:.1f} x real time)")
    print(f"two environments, a process each: {apart:.0f} steps/s, {apart / single:.2f} x one")
    print(f"two environments in lockstep (AsyncVectorEnv): {double:.0f} steps/s, "
          f"{double / single:.2f} x one (target: at least 1000 steps/s on 2 cores)")
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"one_steps_per_s": single, "two_processes_steps_per_s": apart,
                       "lockstep_steps_per_s": double}, fh)


if __name__ == "__main__":
    main()
