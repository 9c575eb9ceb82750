"""A robustness benchmark of the controller presets.

In the structure of the double-pendulum robustness benchmark used in the
underactuated-robotics community: the nominal swing is repeated while one
thing at a time is made worse, in categories

* ``model parameters``: one true-plant quantity at a time scaled by a factor
  (the controller keeps the nominal model);
* ``sensor noise``: both IMU noise levels scaled;
* ``torque noise``: white noise on the applied elbow torque;
* ``delay``: actuation delay of 10..40 ms;
* ``gusts``: random torque pulses on both joints (2 per second, 0.1 s);
* ``incline``: the line inclined up or down;
* ``link-2 parameters``: m2, I2 or lc2 of the real robot off by 10-20 %;
* ``IMU bias and misalignment``: gyro biases of 0.03 rad/s, accelerometers
  mounted 2.5 deg off;
* ``grip spacing``: the grippers 1.1-1.3 m apart;
* ``knockdown``: one knock of severity 0.5-2 (a knock of severity 1 alone
  would swing the free link 30 deg from rest, motor off) at a random
  moment of the swing's first 2.5 sqrt(L/g), on a joint drawn
  (:func:`~bplir_drake.analysis.model.knock.swing_knock`); whole traversals
  knocked at random are ``bplir traverse --knocks``.

Each category scores the fraction of successful swings over its cases (and
``repeats`` noise seeds per case); the overall score is the mean of the
category scores.  Every controller preset sees the same cases and seeds.
"""
from __future__ import annotations

import csv
import zlib
from pathlib import Path

import numpy as np

from ...params import BplirParams, ParameterError, plugin_name
from .executors import map_jobs
from .study_plots import quantity_label
from .sampling import apply_values, base_value, error_text, pinned
from ..swing.swing_runner import run_swing
from ..model.knock import swing_knock
from ...io import DictResult, Record, atomic_path
from ...plotting import figure_axes, finish

MODEL_FIELDS = ("true_plant.m1", "true_plant.m2", "true_plant.I1", "true_plant.I2",
                "true_plant.lc1", "true_plant.lc2", "true_friction.fv1", "true_friction.fv2",
                "true_friction.fc1", "true_friction.fc2")


def cases(quick: bool = False) -> list[dict]:
    """[{category, label, changes: {"block.field": ("scale"|"set", value)}}]."""
    out = []

    def add(category, label, **changes):
        out.append({"category": category, "label": label, "changes": changes})

    fields = ("true_plant.m2", "true_plant.I2", "true_plant.lc2", "true_friction.fc2") \
        if quick else MODEL_FIELDS
    factors = (0.8, 1.2) if quick else (0.6, 0.8, 1.2, 1.4)
    for f in fields:
        for k in factors:
            add("model parameters", f"{f} x{k:g}", **{f: ("scale", k)})
    for k in ((3.0, 10.0) if quick else (2.0, 5.0, 10.0, 20.0)):
        add("sensor noise", f"IMU noise x{k:g}",
            **{"imu.gyro_sigma": ("scale", k), "imu.accel_sigma": ("scale", k)})
    for v in ((1.0, 3.0) if quick else (0.5, 1.0, 2.0, 4.0)):
        add("torque noise", f"{v:g} N m", **{"scenario.torque_noise": ("set", v)})
    for v in ((0.01, 0.03) if quick else (0.01, 0.02, 0.03, 0.04)):
        add("delay", f"{1000 * v:.0f} ms", **{"scenario.actuation_delay": ("set", v)})
    for v in ((2.0, 5.0) if quick else (1.0, 2.0, 4.0, 8.0)):
        add("gusts", f"{v:g} N m", **{"scenario.gust_torque": ("set", v),
                                      "scenario.gust_rate": ("set", 2.0)})
    for v in ((-10.0, 10.0) if quick else (-20.0, -10.0, 10.0, 20.0)):
        add("incline", f"{v:+g} deg", **{"scenario.incline_deg": ("set", v)})
    for f in ("true_plant.m2", "true_plant.I2", "true_plant.lc2"):
        for k in ((0.9, 1.1) if quick else (0.8, 0.9, 1.1, 1.2)):
            add("link-2 parameters", f"{f} x{k:g}", **{f: ("scale", k)})
    imu = [("gyro bias +/-0.03 rad/s", {"imu.gyro_bias1": 0.03, "imu.gyro_bias2": -0.03}),
           ("misalignment +/-2.5 deg", {"imu.misalign1": 0.0436, "imu.misalign2": -0.0436})]
    if not quick:
        imu += [("gyro bias -/+0.03 rad/s", {"imu.gyro_bias1": -0.03, "imu.gyro_bias2": 0.03}),
                ("bias and misalignment", {"imu.gyro_bias1": 0.02, "imu.gyro_bias2": 0.02,
                                           "imu.misalign1": -0.03, "imu.misalign2": 0.03})]
    for label, values in imu:
        add("IMU bias and misalignment", label, **{k: ("set", v) for k, v in values.items()})
    for v in ((1.1, 1.3) if quick else (1.1, 1.15, 1.25, 1.3)):
        add("grip spacing", f"{v:g} m", **{"scenario.grip_spacing": ("set", v)})
    for v in ((1.0, 2.0) if quick else (0.5, 1.0, 1.5, 2.0)):
        out.append({"category": "knockdown", "label": f"severity {v:g}", "changes": {},
                    "knock": v})
    return out


CATEGORIES = ("model parameters", "sensor noise", "torque noise", "delay", "gusts", "incline",
              "link-2 parameters", "IMU bias and misalignment", "grip spacing", "knockdown")


def case_params(params: BplirParams, controller: str, changes: dict,
                args=()) -> BplirParams:
    """The nominal robot (true = nominal, no friction draw) flying
    ``controller`` (a plug-in's factory arguments ``args``; a preset takes
    none) with ``changes``."""
    p = pinned(params.with_controller(controller, args))
    return apply_values(p, {name: base_value(p, name) * value if how == "scale" else value
                            for name, (how, value) in changes.items()})


def case_seed(root: int, case: dict, repeat: int) -> int:
    """Noise seed of one case and repeat: from its name, so a case keeps its
    seed whichever other cases or categories are run."""
    key = zlib.crc32(f"{case['category']}/{case['label']}".encode())
    return int(np.random.SeedSequence([root, key, repeat]).generate_state(1, np.uint32)[0])


class BenchmarkRow(Record):
    """One case, controller and repeat of a benchmark (:data:`CASE_COLUMNS`),
    read as attributes or as the columns of ``benchmark_cases.csv``."""


def _run_case(params: BplirParams, job: dict) -> BenchmarkRow:
    """The row of one case (a job: its controller, changes, repeat and seed)."""
    row = BenchmarkRow({k: job[k] for k in ("controller", "category", "label", "case", "repeat",
                                            "seed")})
    try:
        p = case_params(params, job["controller"], job["changes"], job["controller_args"])
        pulses = (swing_knock(p.plant, job["knock"], job["seed"]) if job.get("knock")
                  else None)
        s = run_swing(p, seed=job["seed"], pulses=pulses).summary
        row |= {"outcome": s.outcome, "success": bool(s.success),
                "capture_speed_mps": s.capture_speed_mps, "swing_time_s": s.swing_time_s,
                "peak_torque_Nm": s.peak_torque_Nm, "peak_motor_power_W": s.peak_motor_power_W,
                "energy_in_J": s.energy_in_J, "error": ""}
    except Exception as exc:
        nan = float("nan")
        row |= {"outcome": "error", "success": False, "capture_speed_mps": nan,
                "swing_time_s": nan, "peak_torque_Nm": nan, "peak_motor_power_W": nan,
                "energy_in_J": nan, "error": error_text(exc)}
    return row


def run_benchmark(params: BplirParams, controllers=("plan", "cpfl-qft", "lab"), *,
                  quick: bool = False, repeats: int | None = None, seed: int = 0,
                  workers: int = 0, progress: bool = False, out=None,
                  categories=CATEGORIES, controller_args=()) -> dict:
    """Score each controller preset; returns scores and the per-case rows.
    ``categories`` restricts the benchmark to some of :data:`CATEGORIES`;
    ``controller_args`` (``"key=value"`` each) go to the plug-ins' factories."""
    for c in controllers:
        params.with_controller(c, controller_args)  # unknown names fail here, before any work
    repeats = (1 if quick else 3) if repeats is None else repeats
    unknown = set(categories) - set(CATEGORIES)
    if unknown:
        raise ParameterError(f"unknown benchmark category {sorted(unknown)[0]!r}; allowed: "
                             + ", ".join(CATEGORIES))
    chosen = [c for c in cases(quick) if c["category"] in categories]
    jobs = []
    for ci, case in enumerate(chosen):
        for r in range(repeats):
            for c in controllers:
                jobs.append((params, case | {"controller": c, "case": ci, "repeat": r,
                                             "seed": case_seed(seed, case, r),
                                             "controller_args": tuple(controller_args)}))
    rows = sorted(map_jobs(_run_case, jobs, workers=workers, progress=progress,
                           desc="benchmark"),
                  key=lambda r: (r.controller, r.case, r.repeat))
    scores = {}
    for c in controllers:
        mine = [r for r in rows if r.controller == c]
        cat = {k: float(np.mean([r.success for r in mine if r.category == k]))
               for k in CATEGORIES if k in categories}
        scores[c] = {"categories": cat, "overall": float(np.mean(list(cat.values()))),
                     "swings": len(mine)}
    if out is not None:
        write_cases_csv(rows, Path(out) / "benchmark_cases.csv")
    return BenchmarkResult({"scores": scores, "quick": quick, "repeats": repeats, "seed": seed,
                            "estimator": params.estimator.plugin or "ekf",
                            "categories": [k for k in CATEGORIES if k in categories],
                            "cases": chosen, "rows": rows})


class BenchmarkResult(DictResult):
    """What :func:`run_benchmark` returns: the dict ``benchmark.json`` holds
    (``scores``, ``cases``, ``rows``, ...) and a result: ``plot()`` draws
    :func:`plot_benchmark`, ``to_pandas()`` has a row per case, controller
    and repeat."""

    def plot(self, axes=None):
        """Scores by category and every case's outcome (two axes)."""
        return plot_benchmark(self, axes)

    def table(self) -> list:
        """The per-case rows."""
        return self["rows"]


CASE_COLUMNS = ("controller", "category", "label", "case", "repeat", "seed", "outcome",
                "success", "capture_speed_mps", "swing_time_s", "peak_torque_Nm",
                "peak_motor_power_W", "energy_in_J", "error")


def leaderboard(result: dict, realistic: dict | None = None) -> list[dict]:
    """One entry per controller, best first: the estimator it ran with
    (``"ekf"`` or a plugin), overall and category scores,
    the median capture speed (m/s) of its captured swings, mean energy put
    in per swing (J) and the largest peak motor power (W) over the
    benchmark's swings; with ``realistic`` (controller -> a Monte Carlo
    summary) its success rate and Wilson interval."""
    board = []
    for c, sc in result["scores"].items():
        mine = [r for r in result["rows"] if r["controller"] == c and r["outcome"] != "error"]
        speeds = [r["capture_speed_mps"] for r in mine if r["success"]]
        entry = {"controller": c, "estimator": result.get("estimator", "ekf"),
                 "overall": sc["overall"], "categories": sc["categories"],
                 "capture_speed_median_mps": float(np.median(speeds)) if speeds else None,
                 "energy_per_swing_J": float(np.mean([r["energy_in_J"] for r in mine]))
                 if mine else None,
                 "peak_power_max_W": float(np.max([r["peak_motor_power_W"] for r in mine]))
                 if mine else None}
        if realistic and c in realistic:
            entry["realistic_success_rate"] = realistic[c]["success_rate"]
            entry["realistic_ci95"] = realistic[c]["success_rate_ci95"]
            entry["realistic_samples"] = realistic[c]["samples"]
        board.append(entry)
    return sorted(board, key=lambda e: (-(e.get("realistic_success_rate") or 0.0),
                                        -e["overall"], e["controller"]))


def leaderboard_table(board: list[dict]) -> str:
    """The leaderboard as a Markdown table."""
    def num(v, fmt):
        return "--" if v is None else format(v, fmt)

    real = any("realistic_success_rate" in e for e in board)
    head = ["rank", "controller", "estimator", "overall"] \
        + (["realistic study (95 % CI)"] if real else []) \
        + ["capture speed median (m/s)", "energy per swing (J)", "peak power max (W)"]
    lines = ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head)]
    for i, e in enumerate(board, 1):
        cells = [str(i), f"`{plugin_name(e['controller'])}`",
                 f"`{plugin_name(e.get('estimator', 'ekf'))}`",
                 f"{e['overall']:.2f}"]
        if real:
            lo, hi = e.get("realistic_ci95", (None, None))
            cells.append(f"{e['realistic_success_rate']:.1%} ({lo:.1%}-{hi:.1%}, "
                         f"n = {e['realistic_samples']})" if "realistic_success_rate" in e
                         else "--")
        cells += [num(e["capture_speed_median_mps"], ".2f"), num(e["energy_per_swing_J"], ".1f"),
                  num(e["peak_power_max_W"], ".0f")]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def write_cases_csv(rows, path) -> Path:
    """One CSV row per benchmark case at ``path`` (atomic)."""

    path = Path(path)
    with atomic_path(path) as tmp, tmp.open("w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(CASE_COLUMNS)
        for r in rows:
            w.writerow([r[c] for c in CASE_COLUMNS])
    return path


def benchmark_table(result: dict) -> str:
    """The benchmark's scores by controller and category as a Markdown table."""
    ctrls = list(result["scores"])
    lines = ["| category | " + " | ".join(ctrls) + " |", "| --- " * (len(ctrls) + 1) + "|"]
    for k in result["categories"]:
        lines.append(f"| {k} | " + " | ".join(f"{result['scores'][c]['categories'][k]:.2f}"
                                              for c in ctrls) + " |")
    lines.append("| **overall** | " + " | ".join(f"**{result['scores'][c]['overall']:.2f}**"
                                                 for c in ctrls) + " |")
    return "\n".join(lines)


def _case_name(case: dict) -> str:
    """A case as a reader names it: a scaled parameter of the simulated
    robot by its meaning ("mass of link 2 x1.2"), the others by their own
    label."""
    field, _, factor = case["label"].rpartition(" ")
    if not field.startswith("true_"):   # a parameter's field name, scaled
        return case["label"]
    return f"{quantity_label(field).split(': ', 1)[-1].split(' [')[0]} {factor}"


def _case_grid(ax, result: dict, ctrls: list) -> None:
    """The success fraction of each controller (columns) in every case
    (rows, readable names, grouped by category)."""
    named = list(result["cases"])
    grid = np.zeros((len(named), len(ctrls)))
    for r in result["rows"]:
        grid[r["case"], ctrls.index(r["controller"])] += r["success"] / result["repeats"]
    ax.imshow(grid, aspect="auto", cmap="RdYlGn", vmin=0, vmax=1, interpolation="nearest")
    ax.set_xticks(range(len(ctrls)), [plugin_name(c) for c in ctrls], rotation=30, ha="right")
    ax.set_yticks(range(len(named)), [_case_name(c) for c in named], fontsize=7)
    ax.yaxis.tick_right()
    for k in range(1, len(named)):   # a rule between categories, named at its first case
        if named[k]["category"] != named[k - 1]["category"]:
            ax.axhline(k - 0.5, color="k", lw=0.8)
    for k, c in enumerate(named):
        if k == 0 or c["category"] != named[k - 1]["category"]:
            ax.text(-0.6, k - 0.4, c["category"], ha="right", va="top", fontsize=8,
                    transform=ax.transData, clip_on=False)
    ax.set_title("success per case (green: every swing captured)", fontsize=9)


def plot_benchmark(result: dict, axes=None):
    """Scores by category and the outcome of every case (two axes); returns the figure."""
    ctrls = list(result["scores"])
    fig, (ax, ax2) = figure_axes(axes, 1, 2, figsize=(13, max(7.5, 0.16 * len(result["cases"]))),
                                 gridspec_kw={"width_ratios": [3, 2]})
    cats = result["categories"]
    x = np.arange(len(cats) + 1)
    w = 0.8 / max(1, len(ctrls))
    for i, c in enumerate(ctrls):
        sc = result["scores"][c]
        vals = [sc["categories"][k] for k in cats] + [sc["overall"]]
        ax.bar(x + (i - (len(ctrls) - 1) / 2) * w, vals, w, label=plugin_name(c))
    ax.set_xticks(x, list(cats) + ["overall"], rotation=30, ha="right")
    ax.set_ylim(0, 1.0)
    ax.set_ylabel("fraction of successful swings")
    # above the axes: the legend never covers a bar
    ax.legend(loc="lower left", bbox_to_anchor=(0.0, 1.01), ncol=min(len(ctrls), 3),
              frameon=False, fontsize=8)
    _case_grid(ax2, result, ctrls)
    return finish(fig, "Robustness benchmark",
                  f"{'quick' if result['quick'] else 'full'} benchmark, root seed "
                  f"{result['seed']}, {result['repeats']} swing(s) per case and controller")
