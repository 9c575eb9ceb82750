"""Generate the results pages and the README's results table from the
stored outputs in ``results/`` (a maintainer's tool).

    python scripts/results_pages.py           # write docs/results/index.md and the README table
    python scripts/results_pages.py --check   # exit 1 if either is out of date

``results/manifest.toml`` lists every stored output: where it is, which
group and row it belongs to, the command that made it and whether its root
seed was used for tuning or held out.  Re-run a study into its directory,
then this script, and the pages follow.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))   # the package of this checkout (its plug-in names)
RESULTS = ROOT / "results"
PAGE = ROOT / "docs" / "results" / "index.md"
README = ROOT / "README.md"
BEGIN, END = "<!-- results-table -->", "<!-- /results-table -->"
HW_BEGIN, HW_END = "<!-- hardware-table -->", "<!-- /hardware-table -->"


def manifest() -> list[dict]:
    """The stored outputs, in the manifest's order, each with its summary."""
    items = tomllib.loads((RESULTS / "manifest.toml").read_text())["output"]
    for item in items:
        name = item.get("file", "summary.json")
        item["summary"] = json.loads((RESULTS / item["path"] / name).read_text())
    return items


def pct(x: float, digits: int = 1) -> str:
    return "--" if x is None or not math.isfinite(x) else f"{100 * x:.{digits}f} %"


def num(x, fmt: str = "{:.3f}") -> str:
    return "--" if x is None or not math.isfinite(float(x)) else fmt.format(float(x))


def _p(s: dict, field: str, q: str):
    return s.get("percentiles", {}).get(field, {}).get(q, math.nan)


def rate(s: dict) -> str:
    """``successes / samples`` and the rate."""
    return f"{s['successes']} / {s['samples']} ({pct(s['success_rate'])})"


def wilson(s: dict) -> str:
    lo, hi = s["success_rate_ci95"]
    return f"{pct(lo)} - {pct(hi)}"


def misses(s: dict) -> str:
    """The outcomes other than the success, or the traversal's miss classes."""
    if "traverse" in s:
        classes = s["traverse"]["miss_classes"]
    else:
        classes = {k: v for k, v in s["outcomes"].items() if k != "captured"}
    return ", ".join(f"{v} {k}" for k, v in sorted(classes.items())) or "none"


def swing_row(item: dict) -> list[str]:
    s = item["summary"]
    return [item["label"], str(s["seed"]), item["role"], rate(s), wilson(s),
            f"{num(_p(s, 'capture_speed_mps', 'p50'))} / "
            f"**{num(_p(s, 'capture_speed_mps', 'p95'))}**",
            f"{num(_p(s, 'peak_voltage_V', 'p95'), '{:.1f}')} / "
            f"{num(_p(s, 'peak_voltage_V', 'max'), '{:.1f}')}",
            num(_p(s, "on_envelope_s", "p95"), "{:.3f}"), misses(s)]


def traverse_row(item: dict) -> list[str]:
    s = item["summary"]
    hw = s.get("hardware", {})
    return [item["label"], str(s["seed"]), item["role"], rate(s), wilson(s),
            f"{hw.get('supply_voltage_V', math.nan):g} V",
            num(_p(s, "peak_voltage_V", "max"), "{:.1f}"), misses(s)]


def knockdown_row(item: dict) -> list[str]:
    """A knocked traversal study: its uptime, runs without a fall and why the
    others fell, the knocks it met by phase."""
    s = item["summary"]
    kd = s["knockdown"]
    lo, hi = kd["no_fall_ci95"]
    falls = ", ".join(f"{k} {v}" for k, v in sorted(kd["falls_by_cause"].items())) or "none"
    met = ", ".join(f"{k} {v}" for k, v in kd["knocks_by_phase"].items() if v) or "none"
    return [item["label"], f"{kd['knocks']['rate']:g} / min, {kd['knocks']['severity']:g}",
            str(s["seed"]), item["role"], f"{kd['mean_uptime']:.3f}",
            f"{kd['no_fall']} / {kd['runs']}", f"{100 * lo:.1f} % - {100 * hi:.1f} %", falls,
            str(kd["interlock_falls"]), f"{kd['knocks_met']} ({met})",
            num(_p(s["traverse"], "speed_m_per_min", "p50"), "{:.1f}")]


def benchmark_rows(item: dict) -> list[list[str]]:
    """One row per controller of a stored benchmark: overall and per category."""
    from bplir_drake.params import plugin_name

    res = item["summary"]
    return [[item["label"], plugin_name(c), f"{sc['overall']:.3f}"]
            + [f"{sc['categories'][k]:.2f}" for k in res["categories"]]
            for c, sc in res["scores"].items()]


def accuracy_rows(item: dict) -> list[list[str]]:
    """One row per line and setting of a stored integrator comparison
    (``benchmarks/bench_accuracy.py --json``)."""
    from bplir_drake.analysis.montecarlo.statistics import wilson_interval

    res, out = item["summary"], []
    for line in res["lines"]:
        for name, st in line["settings"].items():
            integrator, accuracy = res["settings"][name]
            k, n = st["captured"], st["samples"]
            err = st.get("rk5_median_error_mps")
            incline = line["incline_deg"]
            out.append([f"{incline:+.0f}°" if incline else "0°", f"{integrator} {accuracy:g}",
                        f"{k} / {n}", wilson({"success_rate_ci95": wilson_interval(k, n)}),
                        f"{num(st['p50_mps'])} / {num(st['p95_mps'])}",
                        pct(line["same_outcome"]), num(line["median_change_mps"], "{:.4f}"),
                        "--" if err is None else num(err, "{:.5f}")])
    return out


def _limits_of(res: dict, st: dict) -> list[str]:
    """The limit lines of a commissioning that concern this study's gripper."""
    g = st.get("holding", 1)
    lines = res["limits"] + [f"{x} (not shown)" for x in res.get("unshown", [])]
    return [x.split(": ", 1)[1] if x.startswith(f"gripper {g}: ") else x for x in lines
            if x.startswith(f"gripper {g}: ") or not x.startswith("gripper ")]


def commission_rows(item: dict) -> list[list[str]]:
    """One row per incline of a stored ``bplir commission`` (its
    ``commission.json``)."""
    res, out = item["summary"], []
    plans = res["plans"]
    for st in res["studies"]:
        lo, hi = st["wilson95"]
        kind, chosen = st.get("manoeuvre", "swing"), st.get("chosen", True)
        by = "" if kind == "swing" and chosen else f", {kind}"
        verdict = ("ready" if not _limits_of(res, st) else "; ".join(_limits_of(res, st))) \
            if chosen else "not chosen: the other manoeuvre's study does better"
        out.append([f"{item['label']}, gripper {st.get('holding', 1)}{by}",
                    f"{st['incline_deg']:+g}°" if st["incline_deg"] else "0°",
                    str(st["seed"]), f"{plans['solved']} / {plans['points']} "
                    f"({plans['from_similarity']} by similarity)", f"{res['wall_s']:.0f}",
                    f"{st['captured']} / {st['samples']}",
                    f"{100 * lo:.1f} % - {100 * hi:.1f} %",
                    f"{num(st['capture_speed_p50_mps'])} / {num(st['capture_speed_p95_mps'])}",
                    verdict])
    studied = {st.get("holding", 1) for st in res["studies"]}
    for g in sorted({p.get("holding", 1) for p in res["grid"]} - studied):   # no plan at all
        out.append([f"{item['label']}, gripper {g}", "0°", "--",
                    f"{plans['solved']} / {plans['points']}", f"{res['wall_s']:.0f}", "--", "--",
                    "--", "; ".join(_limits_of(res, {"holding": g}))])
    return out


HEADERS = {
    "swing": ["line", "root seed", "seeds", "captured", "Wilson 95 %",
              "capture speed p50 / p95 (m/s)", "peak voltage p95 / max (V)",
              "on the envelope p95 (s)", "misses"],
    "traverse": ["line", "root seed", "seeds", "passed", "Wilson 95 %", "supply",
                 "peak voltage max (V)", "misses"],
    "knockdown": ["robot, line", "knocks, severity", "root seed", "seeds", "mean uptime",
                  "no fall", "Wilson 95 %", "falls", "the interlock's falls",
                  "knocks met (in the simulation, by phase)", "m/min p50"],
    "commission": ["robot, holding with", "line", "root seed", "plans (both grippers)",
                   "wall time (s)", "captured", "Wilson 95 %", "capture speed p50 / p95 (m/s)",
                   "verdict"],
    "accuracy": ["line", "integrator", "captured", "Wilson 95 %",
                 "capture speed p50 / p95 (m/s)", "same outcome", "median change (m/s)",
                 "median error against RK5 1e-10 (m/s)"],
}


def table(header: list[str], rows: list[list[str]]) -> list[str]:
    return (["| " + " | ".join(header) + " |", "|" + " --- |" * len(header)]
            + ["| " + " | ".join(r) + " |" for r in rows])


def page(items: list[dict]) -> str:
    """docs/results/index.md."""
    groups: dict[str, list[dict]] = {}
    for item in items:
        groups.setdefault(item["group"], []).append(item)
    desc = tomllib.loads((RESULTS / "manifest.toml").read_text()).get("group", {})
    out = ["# Results", "",
           "Generated by `python scripts/results_pages.py` from the stored outputs in "
           "`results/` (each study's `summary.json`, with its `study.toml`); do not edit by "
           "hand.  *Seeds*: `tuning` root seeds were used to choose a parameter, `held out` "
           "ones were not used for any choice.  Rates carry their 95 % Wilson intervals.", ""]
    for name, members in groups.items():
        info = desc.get(name, {})
        out += [f"## {info.get('title', name)}", "", info.get("text", ""), ""]
        if name == "hardware":
            out += ["Captured of 300 and the capture speed's p95 (m/s):", "",
                    hardware_matrix(items), ""]
        kind = members[0].get("kind", "swing")
        if kind == "benchmark":
            cats = list(members[0]["summary"]["categories"])
            rows = [r for i in members for r in benchmark_rows(i)]
            out += table(["benchmark", "controller", "overall", *cats], rows) + [""]
        elif kind == "commission":
            rows = [r for i in members for r in commission_rows(i)]
            out += table(HEADERS[kind], rows) + [""]
        elif kind == "knockdown":
            out += table(HEADERS[kind], [knockdown_row(i) for i in members]) + [""]
        elif kind == "accuracy":
            rows = [r for i in members for r in accuracy_rows(i)]
            out += table(HEADERS[kind], rows) + [""]
            out += [f"The default swing's seeds 0-19: {i['summary']['default_seeds_kept']} of 20 "
                    "keep their outcome." for i in members] + [""]
        else:
            rows = [swing_row(i) if kind == "swing" else traverse_row(i) for i in members]
            out += table(HEADERS[kind], rows) + [""]
        version = members[0]["summary"].get("package_version", "0.2.0.dev0")
        out += [f"How each row was produced (version {version}):", ""]
        out += [f"- {i['label']}: `{i['command']}`" for i in members] + [""]
    return "\n".join(out).rstrip() + "\n"


def readme_table(items: list[dict]) -> str:
    """The README's summary: one row per headline figure, each from its output."""
    rows = []
    for item in items:
        if not item.get("readme"):
            continue
        s = item["summary"]
        lo, hi = s["success_rate_ci95"]
        figure = f"{pct(s['success_rate'])} (Wilson {pct(lo)} - {pct(hi)}, n = {s['samples']})"
        if item.get("kind", "swing") == "swing":
            figure += f"; capture speed p95 {num(_p(s, 'capture_speed_mps', 'p95'))} m/s"
        rows.append([item["readme"], figure, f"[{item['group']}](docs/results/index.md)"])
    return "\n".join(table(["what", "measured", "page"], rows))


def hardware_matrix(items: list[dict]) -> str:
    """Robot (supply, sensors) by line: captures and the capture speed's p95."""
    cells: dict[str, dict[str, str]] = {}
    lines: list[str] = []
    for item in items:
        if item["group"] != "hardware":
            continue
        line, robot = item["label"].split(", ", 1)
        s = item["summary"]
        if line not in lines:
            lines.append(line)
        cells.setdefault(robot, {})[line] = (
            f"{s['successes']}/{s['samples']}, p95 {num(_p(s, 'capture_speed_mps', 'p95'), '{:.2f}')}")
    rows = [[robot] + [c.get(line, "--") for line in lines] for robot, c in cells.items()]
    hw = [i for i in items if i["group"] == "hardware"]
    runs = sorted({(i["summary"]["samples"], i["summary"]["seed"], i["role"]) for i in hw})
    said = "; ".join(f"{n} swings per cell, root seed {seed} ({role})" for n, seed, role in runs)
    return "\n".join([f"Captured of {said}:", ""] + table(
        ["robot"] + [f"{line} line" for line in lines], rows))


def _replace(text: str, begin: str, end: str, body: str) -> str:
    if begin not in text:
        return text
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    return f"{head}{begin}\n{body}\n{end}{tail}"


def readme_text(items: list[dict]) -> str:
    text = _replace(README.read_text(), BEGIN, END, readme_table(items))
    return _replace(text, HW_BEGIN, HW_END, hardware_matrix(items))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--check", action="store_true", help="fail if a page is out of date")
    args = ap.parse_args(argv)
    items = manifest()
    want = {PAGE: page(items), README: readme_text(items)}
    stale = [p for p, text in want.items() if not p.exists() or p.read_text() != text]
    if args.check:
        for p in stale:
            print(f"out of date: {p.relative_to(ROOT)}", file=sys.stderr)
        return 1 if stale else 0
    for p in stale:
        p.write_text(want[p])
        print(f"wrote {p.relative_to(ROOT)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
