"""One built swing diagram serves many Monte Carlo samples: a sample lives
in the context (the simulated links' inertial parameters, friction, IMU
errors and noise seed, wind and gusts), and running it through a reused
diagram gives exactly what a freshly built diagram gives."""
from dataclasses import replace

import re
from pathlib import Path

import numpy as np
import pytest

from bplir_drake.analysis.montecarlo import Distribution, Study, sample_params
from bplir_drake.analysis.swing.swing_runner import SwingRunner, run_swing, swing_diagram
from bplir_drake.diagrams import build_swing, set_swing_sample, swing_structure
from bplir_drake.params import BplirParams


def _study() -> Study:
    base = BplirParams()
    base = base.with_(scenario=replace(base.scenario, gust_rate=2.0, gust_torque=1.0))
    dists = (Distribution("true_friction.fv1", "uniform", rel=0.2),
             Distribution("true_friction.fc2", "uniform", rel=0.2),
             Distribution("true_plant.m2", "uniform", rel=0.1),
             Distribution("true_plant.I2", "uniform", rel=0.1),
             Distribution("true_plant.lc2", "uniform", abs=0.01),
             Distribution("imu.gyro_bias1", "uniform", abs=0.01),
             Distribution("imu.gyro_sigma", "uniform", rel=0.5),
             Distribution("scenario.gust_torque", "uniform", rel=0.5))
    return Study(base, dists, samples=3, seed=11)


@pytest.mark.slow
def test_three_samples_through_one_diagram_equal_three_fresh_builds():
    study = _study()
    runner = SwingRunner()
    for index in range(3):
        p, seed, drawn = sample_params(study, index)
        reused = runner.run(p, seed=seed)
        fresh = run_swing(p, seed=seed)
        assert reused.summary == fresh.summary
        for name, log in fresh.logs.items():
            np.testing.assert_array_equal(reused.logs[name].t, log.t)
            np.testing.assert_array_equal(reused.logs[name].data, log.data)
    assert runner.builds == 1
    # the samples really differ (the context carried something)
    speeds = {runner.run(*sample_params(study, i)[:1], seed=sample_params(study, i)[1])
              .summary["capture_speed_mps"] for i in range(3)}
    assert len(speeds) == 3


def test_a_structural_change_is_refused_and_rebuilt():
    """A sample of the built parameters goes into the context as they are
    (``path.mode`` "auto" unresolved included); a change the context
    cannot carry is refused naming the field, and a runner rebuilds."""
    p = BplirParams()
    built = swing_diagram(p, seed=0)
    assert build_swing(p, seed=0).structure == built.structure   # gains fetched by either
    ctx = built.diagram.CreateDefaultContext()
    assert p.path.mode == "auto"
    set_swing_sample(built, ctx, p.with_(true_friction=replace(p.friction, fv1=0.2)), 3)
    other = p.with_(scenario=replace(p.scenario, grip_spacing=1.3))   # a shipped plan
    assert swing_structure(other, True) != built.structure
    with pytest.raises(ValueError, match="this sample changes scenario.grip_spacing, more "
                                         ".* build its own swing diagram"):
        set_swing_sample(built, ctx, other, 0)
    runner = SwingRunner()
    runner.run(p, seed=0)
    runner.run(other, seed=0)
    assert runner.builds == 2


def test_results_plot_on_the_callers_axes_and_serialise(tmp_path):
    """Results draw on axes a user passes (and leave that figure's layout
    alone) or on a new figure; they serialise to strict JSON."""
    import json

    from matplotlib.figure import Figure

    from bplir_drake.analysis.model.freeswing import simulate_free_swing
    from bplir_drake.plotting import save_figure

    res = simulate_free_swing(BplirParams(), (0.5, 0.2), 1.0)
    own = res.plot()
    assert len(own.axes) == 3 and own._suptitle.get_text() == "Free swing"
    np.testing.assert_array_equal(own.axes[0].lines[0].get_xdata(), res.t)
    np.testing.assert_array_equal(own.axes[2].lines[0].get_ydata(), res.total)
    mine = Figure()
    axes = mine.subplots(1, 3)
    assert res.plot(axes) is mine and mine._suptitle is None
    np.testing.assert_array_equal(axes[1].lines[1].get_ydata(), res.x[:, 3])
    with pytest.raises(ValueError, match="draws on 3 axes; 2 given"):
        res.plot(Figure().subplots(1, 2))
    assert save_figure(own, tmp_path / "f.png").read_bytes()[:4] == b"\x89PNG"
    data = json.loads(res.to_json())
    assert data == res.summary()  # JSON round trip of plain floats is exact
    assert data["energy_end_J"] < data["energy_start_J"]  # friction dissipates


def _modules():
    import ast

    repo = Path(__file__).resolve().parents[1]
    for path in _package_files():
        yield path.relative_to(repo), ast.parse(path.read_text())


def _fresh_python(code: str) -> str:
    """What ``code`` prints in a fresh interpreter (it must succeed)."""
    import subprocess
    import sys

    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True).stdout


def test_every_public_definition_has_a_docstring():
    import ast

    missing = []
    for rel, tree in _modules():
        def visit(node, prefix=""):
            for n in ast.iter_child_nodes(node):
                if isinstance(n, (ast.FunctionDef, ast.ClassDef)) and not n.name.startswith("_"):
                    if not ast.get_docstring(n):
                        missing.append(f"{rel}:{n.lineno} {prefix}{n.name}")
                    if isinstance(n, ast.ClassDef):
                        visit(n, prefix + n.name + ".")
        visit(tree)
    assert not missing, "\n".join(missing)


# what each layer may import from the package (ARCHITECTURE.md): imports only go down
LAYERS = {"leftovers": set(), "labelled": set(), "io": {"leftovers", "labelled"}, "progress": set(), "csvfile": {"io"}, "plotting": {"io"},
          "params": {"io"},
          "systems": {"params", "io"},
          "planning": {"params", "io", "csvfile", "progress", "plotting", "systems"},
          "diagrams": {"params", "io", "csvfile", "progress", "plotting", "systems", "planning"},
          "simulate": {"params", "io", "systems"},
          "estimation": {"params", "io", "csvfile", "progress", "plotting", "systems"},
          "analysis": {"params", "io", "labelled", "csvfile", "progress", "plotting", "systems", "planning",
                       "diagrams", "simulate", "estimation"},
          "gym": {"params", "io", "labelled", "csvfile", "progress", "plotting", "systems",
                  "planning", "diagrams", "simulate", "estimation", "analysis"},
          "cli": {"params", "io", "csvfile", "progress", "plotting", "systems", "planning",
                  "diagrams", "simulate", "estimation", "analysis"}}


def test_imports_only_go_down_the_layers():
    import ast

    wrong = []
    for rel, tree in _modules():
        parts = rel.with_suffix("").parts[1:]
        layer = parts[0]
        if layer == "__init__":
            continue
        for n in ast.walk(tree):
            if isinstance(n, ast.ImportFrom) and n.level:
                # resolve the relative import against this module's package
                pkg = list(parts[:-1]) if len(parts) > 1 else []
                base = pkg[:len(pkg) - (n.level - 1)] if n.level > 1 else pkg
                target = (base + (n.module.split(".") if n.module else []))
                top = target[0] if target else None
                if top and top != layer and top not in LAYERS[layer]:
                    wrong.append(f"{rel}:{n.lineno} imports {'.'.join(target)}")
    assert not wrong, "\n".join(wrong)


@pytest.mark.slow
def test_the_default_robot_builds_and_swings_without_the_analysis_package():
    """``build_swing(BplirParams())`` in a fresh interpreter: the plan's gains
    come from the layer below analysis, the default context is the swing,
    and a plain ``Simulator`` flies it to a capture -- with no module of
    ``bplir_drake.analysis`` ever imported."""
    code = (
        "import sys\n"
        "from pydrake.systems.analysis import Simulator\n"
        "from bplir_drake.diagrams import build_swing\n"
        "from bplir_drake.params import BplirParams\n"
        "built = build_swing(BplirParams())\n"
        "sim = Simulator(built.diagram)\n"
        "sim.get_mutable_integrator().set_maximum_step_size(0.01)\n"
        "sim.AdvanceTo(BplirParams().scenario.max_time + 0.02)\n"
        "lock = built.systems['interlock']\n"
        "print(lock.outcome(sim.get_context()))\n"
        "print(sorted(m for m in sys.modules if m.startswith('bplir_drake.analysis')))\n")
    assert _fresh_python(code).splitlines() == ["captured", "[]"]


def _import_graph() -> dict[str, set[str]]:
    """Every module of the package and the package modules it imports
    (relative imports, function-local ones included), by dotted name."""
    import ast

    pkg_root = Path(__file__).resolve().parents[1] / "bplir_drake"
    names = {}
    for path in pkg_root.rglob("*.py"):
        parts = ("bplir_drake",) + path.relative_to(pkg_root).with_suffix("").parts
        names[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = (path, parts)
    graph = {}
    for name, (path, parts) in names.items():
        package = list(parts[:-1])
        edges = set()
        for n in ast.walk(ast.parse(path.read_text())):
            if not (isinstance(n, ast.ImportFrom) and n.level):
                continue
            base = package[:len(package) - (n.level - 1)]
            target = base + (n.module.split(".") if n.module else [])
            for alias in n.names:   # "from . import x" may name a module
                sub = ".".join(target + [alias.name])
                edges.add(sub if sub in names else ".".join(target))
        graph[name] = {e for e in edges if e in names and e != name}
    return graph


def test_no_import_circle_between_modules():
    """No module imports, directly or through others, a module that imports
    it -- function-local imports included (a circle hidden by a local import
    still ties the two modules together)."""
    graph = _import_graph()
    index, low, stack, on, circles = {}, {}, [], set(), []

    def visit(v):   # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                circles.append(sorted(comp))

    import sys
    sys.setrecursionlimit(10000)
    for v in graph:
        if v not in index:
            visit(v)
    assert not circles, circles


def test_modules_and_functions_stay_small():
    """No module of the package over 450 lines, no function over 80."""
    import ast

    root = Path(__file__).resolve().parents[1] / "bplir_drake"
    big = []
    for path in root.rglob("*.py"):
        text = path.read_text()
        if len(text.splitlines()) > 450:
            big.append(f"{path.relative_to(root)}: {len(text.splitlines())} lines")
        for n in ast.walk(ast.parse(text)):
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef)):
                size = n.end_lineno - n.lineno + 1
                if size > 80:
                    big.append(f"{path.relative_to(root)}:{n.lineno} {n.name}: {size} lines")
    assert not big, "\n".join(big)


#: what a function may import locally, and why (ARCHITECTURE.md): heavy or
#: optional third-party modules loaded only by the functions that use them,
#: pydrake's binding modules on first use, and platform-specific modules
LAZY_IMPORTS = {"matplotlib", "scipy", "control", "pydrake", "tqdm", "dask", "distributed", "xarray", "tomli_w", "PIL", "pandas",
                "fcntl", "ctypes", "multiprocessing", "concurrent", "signal"}


def test_function_local_imports_only_where_they_save_start_up():
    """Outside the command line (whose commands import their machinery when
    they run, so ``bplir --help`` starts fast), a function imports locally
    only the modules of :data:`LAZY_IMPORTS`; the package's own modules and
    the light standard library are imported at the top."""
    import ast

    root = Path(__file__).resolve().parents[1] / "bplir_drake"
    wrong = []
    for path in root.rglob("*.py"):
        if "cli" in path.relative_to(root).parts:
            continue
        for fn in ast.walk(ast.parse(path.read_text())):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for n in ast.walk(fn):
                if isinstance(n, ast.ImportFrom):
                    top = "." if n.level else n.module.split(".")[0]
                elif isinstance(n, ast.Import):
                    top = n.names[0].name.split(".")[0]
                else:
                    continue
                if top not in LAZY_IMPORTS:
                    wrong.append(f"{path.relative_to(root)}:{n.lineno} {ast.unparse(n)}")
    assert not wrong, "\n".join(sorted(set(wrong)))


def test_calibration_loads_without_python_control():
    """``bplir calibrate`` (and a refusal of its log) does not wait for
    python-control, which only the QFT family of the step fits needs (it
    made the command start 2 s later)."""
    code = ("import sys, bplir_drake.analysis.identification.calibration\n"
            "print('control' in sys.modules, 'scipy.signal' in sys.modules)\n")
    assert _fresh_python(code).strip() == "False False"


def test_the_command_line_starts_without_pydrake():
    """``bplir --help``/``--version`` load the parser alone: importing the
    command line loads neither pydrake, nor matplotlib, scipy or
    python-control (each command imports its machinery when it runs)."""
    code = ("import sys, bplir_drake.cli\n"
            "print(sorted({m.split('.')[0] for m in sys.modules} & "
            "{'pydrake', 'matplotlib', 'scipy', 'control'}))\n")
    assert _fresh_python(code).strip() == "[]"


def test_every_data_file_is_installed_with_the_package():
    """Each file under bplir_drake/data matches a package-data pattern of
    pyproject.toml, so an installed package (pip install ., not editable)
    has its plans and its robot descriptions."""
    import tomllib
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    patterns = tomllib.loads((root / "pyproject.toml").read_text())["tool"]["setuptools"][
        "package-data"]["bplir_drake"]
    package = root / "bplir_drake"
    covered = {p for pattern in patterns for p in package.glob(pattern)}
    data = {p for p in (package / "data").rglob("*") if p.is_file() and "__pycache__" not in p.parts}
    assert data and data <= covered, sorted(str(p.relative_to(package)) for p in data - covered)


def _package_files():
    return sorted((Path(__file__).resolve().parents[1] / "bplir_drake").rglob("*.py"))


def test_no_two_modules_share_a_name():
    """One name per meaning: a module's file name is unique in the package
    (a package's face, ``__init__``, aside)."""
    from collections import Counter

    names = Counter(p.name for p in _package_files() if p.name != "__init__.py")
    assert sorted(n for n, c in names.items() if c > 1) == []


def test_nothing_is_re_exported_outside_a_package_face():
    """A name is imported from the module that defines it: no module but a
    package's ``__init__`` keeps an unused import alive for others."""
    hits = [f"{p.name}:{i}" for p in _package_files() if p.name != "__init__.py"
            for i, line in enumerate(p.read_text().splitlines(), 1) if "noqa: F401" in line]
    assert hits == []


def test_trajectory_optimisation_lives_in_the_planning_layer():
    """Only ``planning/`` solves trajectory optimisations, and it plans on
    the nominal model's system from ``systems``, not on a wired diagram."""
    users = {p.parent.name + "/" + p.name for p in _package_files()
             if re.search(r"import \(?[^)]*\bDirectCollocation\b",
                          p.read_text())}
    assert users and all(u.startswith("planning/") for u in users), users
    assert LAYERS["planning"] == {"params", "io", "csvfile", "progress", "plotting", "systems"}
    assert "planning" in LAYERS["diagrams"] and "diagrams" not in LAYERS["planning"]


def test_the_released_import_paths_still_import():
    """0.1.0 documented ``bplir_drake.analysis.swing.run`` and
    ``bplir_drake.analysis.swing.plan``: code written against them runs."""

    code = ("from bplir_drake.analysis.swing.run import run_swing, SwingResult, write_log_csv, "
            "motor_summary\n"
            "from bplir_drake.analysis.swing.plan import plan_swing, tracking_plan, SwingPlan\n"
            "from bplir_drake.planning.solve import plan_swing as p\n"
            "from bplir_drake.analysis.swing.swing_runner import run_swing as r\n"
            "print(plan_swing is p and run_swing is r)\n")
    assert _fresh_python(code).strip() == "True"
