"""Commissioning a robot: from its description to plans, gains and a
verdict (:func:`commission`)."""
from __future__ import annotations

import shutil
from dataclasses import dataclass, field
import tempfile
import time
from pathlib import Path

from ...planning.library import load_library, robot_library_path
from ...io import atomic_path, write_json_atomic
from ...planning.retry import retry
from ...params import BplirParams, Manoeuvre, derive, on_line, save_toml
from ..montecarlo.runner import check_out, run_study
from ..montecarlo.study import StudyError
from .grid import guess_sources, solve_library
from .margins import (assumptions, binding_line, electric_margins, landing_impact,
                      motor_figures)
from .commission_result import CommissionResult
from .rows import PlanPoint, StudyVerdict
from .similarity import Reference, plan_kind, similar_guesses
from .commission_report import write_report
from .verdict import (DEFAULT_SAMPLES, READY_RATE, miss_reasons, no_plan_reason,
                      study_verdict, verification_study)

#: the default grid of grip spacings: the robot's own +/- this share of its
#: reach (the verification study draws the spacing within it)
SPACING_SHARE = 0.05


def default_spacings(params: BplirParams) -> tuple[float, ...]:
    """The robot's grip spacing and this share of its reach either side (mm)."""
    d, L = params.scenario.grip_spacing, params.plant.l1 + params.plant.l2
    return tuple(round(d + k * SPACING_SHARE * L, 3) for k in (-1, 0, 1))


#: a pump's plan is shifted onto a drawn spacing, not blended with its
#: neighbours' (their link-1 reversals may differ), so its grid splits each
#: gap of the swing's into this many: the shift is at most half as far
PUMP_GRID_DIVISIONS = 2


def pump_spacings(spacings) -> tuple[float, ...]:
    """The grid of a pump's spacings: ``spacings`` with each gap split into
    :data:`PUMP_GRID_DIVISIONS` (mm)."""
    s = sorted(spacings)
    inner = [round(a + k * (b - a) / PUMP_GRID_DIVISIONS, 3) for a, b in zip(s, s[1:])
             for k in range(1, PUMP_GRID_DIVISIONS)]
    return tuple(sorted(s + inner))


def held_by(params: BplirParams, gripper: int) -> tuple[BplirParams, BplirParams]:
    """The robot ``params`` holding with ``gripper`` (2: seen from its other
    gripper), as its single swing from the line and as that swing tried
    again from hanging (a traversal's recovery) are commissioned, whatever
    manoeuvre its ``scenario.manoeuvre`` names: commissioning chooses it."""
    robot = derive(params, Manoeuvre(gripper=gripper, reach="swing"))
    tries = retry(params, Manoeuvre(gripper=gripper, incline_deg=0.0, context="retry"))
    return robot, tries


def commission(params: BplirParams, *, inclines=(0.0,), spacings=None,
               samples: int = DEFAULT_SAMPLES,
               seed: int = 1, out=None, workers: int = 0, progress: bool = False,
               name: str = "robot", grippers=(1, 2), hanging: bool = True, dask: bool = False,
               scheduler: str | None = None, figure: tuple = ("png", 150),
               pumps: bool = True) -> CommissionResult:
    """Commission the robot ``params`` (its plant, friction, motor, IMUs
    and gripper) holding with each of ``grippers`` (2: the robot seen from
    its other gripper, :func:`~bplir_drake.params.swapped`, commissioned by
    the same rules): solve its plan library over ``inclines`` (deg) x
    ``spacings`` (m; default :func:`default_spacings`) from similar robots'
    plans (:mod:`.grid`), run a verification study of ``samples`` swings at
    each incline (root seed ``seed``, :func:`~.verdict.verification_study`)
    and give the verdict.  With ``hanging`` also the library of each
    gripper's swings tried again from hanging (a traversal's recovery,
    :func:`~bplir_drake.analysis.traverse.recovery.retry_params`) on the
    same grid where its swing from the line has a plan (no try of a swing
    that has none): a point without a plan there is a limit too.  With
    ``pumps``, where the single swing leaves a limit, the same grid and
    studies of the pumping manoeuvre (``Manoeuvre(reach="pump")``),
    and the manoeuvre whose studies do better is the robot's (the other's
    rows and studies are kept, ``chosen`` false).  With ``out`` the robot's parameters, its
    libraries, the studies (resumable), ``commission.json``, ``report.md``
    and the figure are written there.  ``workers`` processes on this
    machine, or Dask (``dask``: a local cluster; ``scheduler``: an existing
    one's address); ``figure``: the figure's format and resolution (dpi)."""
    t0 = time.perf_counter()
    inclines = tuple(sorted(float(a) for a in inclines))
    spacings = tuple(sorted(spacings or default_spacings(params)))
    out = None if out is None else Path(out)
    if out is not None:   # before any work: nothing of another robot's is replaced
        check_commission_out(params, out, grippers=grippers, inclines=inclines,
                             spacings=spacings, samples=samples, seed=seed, pumps=pumps)
    pool = dict(workers=workers, dask=dask, scheduler=scheduler, progress=progress)
    refs = []   # the libraries solved so far, in order: later ones start from them
    grid = dict(inclines=inclines, spacings=spacings, samples=samples, seed=seed, out=out,
                pool=pool, refs=refs)
    found = Found()
    for g in grippers:
        robot, tries = held_by(params, g)
        chosen = _manoeuvre(robot, g, **grid)
        if pumps and chosen.limits:
            pump = _manoeuvre(derive(params, Manoeuvre(gripper=g, reach="pump")), g,
                              **(grid | {"spacings": pump_spacings(spacings)}))
            if pump.score() > chosen.score():
                chosen, pump = pump, chosen
            found.add(pump, chosen=False)
        found.add(chosen, chosen=True)
        if hanging and any(p is not None for p in chosen.plans):
            from_hanging = _solved(tries, inclines, spacings, pool, refs)
            found.plans += [r.plan for r in from_hanging.values()]
            found.points += [PlanPoint(r.row(), holding=g, start="hanging")
                             for r in from_hanging.values()]
            found.limits += [f"gripper {g}, from hanging: {_no_plan(tries, r, refs)}"
                             for r in from_hanging.values() if r.plan is None]
    result = CommissionResult(name=name, params=params, points=found.points,
                              studies=found.studies, limits=found.limits, unshown=found.unshown,
                              margins=electric_margins(params, found.plans),
                              motor=motor_figures(params), binding=found.binding,
                              assumed=assumptions(params),
                              seed=seed, wall_s=time.perf_counter() - t0)
    if out is not None:
        _save(result, out, grippers, figure)
    return result


@dataclass
class Found:
    """What commissioning found for one holding gripper's manoeuvre from the
    line (or, merged, for the robot): grid rows, studies, limit lines, the
    lines of studies too small to show the bar, plans, the binding lines."""

    points: list = field(default_factory=list)
    studies: list = field(default_factory=list)
    limits: list = field(default_factory=list)
    unshown: list = field(default_factory=list)
    plans: list = field(default_factory=list)
    binding: dict = field(default_factory=dict)

    def score(self) -> tuple:
        """(studies captured above the bar less the limit lines, the
        studies' mean capture rate): the better manoeuvre scores higher."""
        ok = sum(st.verdict != "below" for st in self.studies)
        rates = [st.rate for st in self.studies]
        return ok - len(self.limits), sum(rates) / max(len(rates), 1)

    def add(self, other: "Found", chosen: bool) -> None:
        """``other``'s rows and studies marked ``chosen``; its limits, plans
        and binding lines only when it is the manoeuvre chosen."""
        self.points += [PlanPoint(p, chosen=chosen) for p in other.points]
        self.studies += [StudyVerdict(st, chosen=chosen) for st in other.studies]
        if chosen:
            self.limits += other.limits
            self.unshown += other.unshown
            self.plans += other.plans
            self.binding |= other.binding


def _solved(robot, inclines, spacings, pool: dict, refs: list) -> dict:
    """The library of ``robot`` on the grid (:func:`~.grid.solve_library`),
    started from the libraries ``refs`` this commission solved before; the
    new library is added to them."""
    solved = solve_library(robot, inclines, spacings, references=tuple(refs), **pool)
    lib = load_library(robot_library_path(robot))
    if lib is not None:
        refs.append(Reference(lib, robot.plant, plan_kind(robot)))
    return solved


def _manoeuvre(robot, g: int, *, inclines, spacings, samples, seed, out, pool,
               refs) -> Found:
    """The robot ``robot`` held by gripper ``g`` reaching the line by its
    manoeuvre (``scenario.manoeuvre``): its library on the grid, the limit
    line of every point without a plan, and a verification study at each
    incline with a plan."""
    kind = robot.scenario.manoeuvre_of()
    solved = _solved(robot, inclines, spacings, pool, refs)
    f = Found(plans=[r.plan for r in solved.values()])
    f.binding[g] = binding_line(robot, f.plans)
    f.points = [PlanPoint(r.row(), holding=g, start="line", manoeuvre=kind)
                for r in solved.values()]
    head = f"gripper {g}: " + ("" if kind == "swing" else "pumping: ")
    f.limits = [head + _no_plan(robot, r, refs) for r in solved.values() if r.plan is None]
    for a in inclines:
        if all(solved[a, d].plan is None for d in spacings):
            continue
        where = None if out is None else out / "studies" / study_name(g, kind, a)
        v, why = _verify(robot, a, solved, samples, seed, spacings, where, pool)
        own = _own_spacing(robot, a, solved, spacings)
        f.studies.append(StudyVerdict(v, holding=g, manoeuvre=kind, impact=None if own is None
                                      else landing_impact(robot, own, v.capture_speed_p95_mps)))
        if why:
            (f.unshown if v.verdict == "not shown" else f.limits).append(head + why)
    return f


def study_name(gripper: int, kind: str, incline: float) -> str:
    """The directory under ``studies/`` of the verification study of the
    robot held by ``gripper`` reaching the line by ``kind`` at ``incline``."""
    how = "" if kind == "swing" else f"_{kind}"
    return f"gripper{gripper}{how}_incline_{incline:+05.1f}"


def check_commission_out(params, out: Path, *, grippers, inclines, spacings, samples,
                         seed, pumps) -> None:
    """Refuse (``StudyError``, nothing written) an ``out`` whose ``plans``
    or ``studies`` is a link (the commission would write where it points),
    or whose studies are another commission's (another robot, other
    samples' seed or grid): every study the commission may run is checked
    before it solves a plan."""
    for part in ("plans", "studies", "robot.toml", "commission.json"):
        if (out / part).is_symlink():
            raise StudyError(f"{out / part} is a symbolic link; a commission writes its "
                             "own files there: remove the link or choose another --out")
    for g in grippers:
        kinds = [("swing", held_by(params, g)[0], spacings)]
        if pumps:
            kinds.append(("pump", derive(params, Manoeuvre(gripper=g, reach="pump")),
                          pump_spacings(spacings)))
        for kind, robot, grid in kinds:
            for a in inclines:
                check_out(verification_study(robot, a, samples, seed, grid),
                          out / "studies" / study_name(g, kind, a))


def _verify(robot, incline, solved, samples, seed, spacings, where, pool):
    """(verdict of the verification study at ``incline``, its line: ""
    when it shows the robot ready, the swings that would show it when its
    rate is above the bar but its interval is not, else why it misses)."""
    study = verification_study(robot, incline, samples, seed, spacings)
    summary, rows = _run(study, where, pool)
    v = StudyVerdict(study_verdict(incline, summary), seed=study.seed)
    if v.verdict == "ready":
        return v, ""
    if v.verdict == "not shown":
        return v, _not_shown(v)
    why = miss_reasons(robot, rows, [r.plan for r in solved.values()])
    return v, "; ".join([_short(v)] + why)


def _own_spacing(robot, incline, solved, spacings):
    """The plan at ``incline`` at the grid's spacing nearest the robot's
    own (None: none there)."""
    d = min(spacings, key=lambda x: abs(x - robot.scenario.grip_spacing))
    plan = solved[incline, d].plan
    return plan if plan is not None and plan.feasible else None


def _run(study, where, pool: dict) -> tuple[dict, list]:
    """The study's summary and rows (run in ``where`` when given, resumable)."""
    with tempfile.TemporaryDirectory() as tmp:
        done = run_study(study, where or Path(tmp) / "study", **pool)
        return dict(done), list(done.result.rows)


def _no_plan(params, res, refs) -> str:
    """The limit line of a grid point without a plan."""
    q = on_line(params, res.incline, res.spacing)
    guesses = similar_guesses(q, guess_sources(refs), count=1)
    return no_plan_reason(params, res.incline, res.spacing, guesses[0] if guesses else None,
                          res.tried)


def _not_shown(v: dict) -> str:
    """The line of a verification study whose rate is above
    :data:`READY_RATE` but whose Wilson interval reaches below it."""
    lo, hi = v.wilson95
    n = v.samples_to_show
    return (f"{v.incline_deg:+g} deg: captured {v.captured}/{v.samples}, Wilson 95 % "
            f"{100 * lo:.1f}-{100 * hi:.1f} %: {v.samples} swings cannot show "
            f"{100 * READY_RATE:.0f} %; {n} capturing as these did would (--samples {n})")


def _short(v: dict) -> str:
    """The limit line of a verification study below :data:`READY_RATE`."""
    misses = ", ".join(f"{n} {k}" for k, n in v.outcomes.items() if k != "captured")
    lo, hi = v.wilson95
    return (f"{v.incline_deg:+g} deg: captured {v.captured}/{v.samples} "
            f"({100 * v.rate:.0f} %, Wilson 95 % {100 * lo:.0f}-{100 * hi:.0f} %), below "
            f"{100 * READY_RATE:.0f} %; misses: {misses}")


def _save(result: CommissionResult, out: Path, grippers, figure) -> None:
    """The result's files in ``out``."""
    robots = [r for g in grippers for r in held_by(result.params, g)]
    robots += [derive(result.params, Manoeuvre(gripper=g, reach="pump")) for g in grippers]
    for lib in (robot_library_path(r) for r in robots):
        if lib.exists():
            (out / "plans").mkdir(exist_ok=True)
            with atomic_path(out / "plans" / lib.name) as tmp:
                shutil.copyfile(lib, tmp)
    out.mkdir(parents=True, exist_ok=True)
    save_toml(result.params, out / "robot.toml")
    write_json_atomic(out / "commission.json", result.to_dict())
    write_report(result, out, *figure)
