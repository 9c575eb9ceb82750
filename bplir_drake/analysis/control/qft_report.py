"""The QFT study of a controller preset, as ``bplir qft`` reports it.

:func:`qft_report` verifies the outer loop (K, F) of a preset against the
specifications on a plant family -- the dissertation's published family
(with and without its delay) or a family linearised from the simulated
diagram -- optionally redesigns it, and computes the data of its four
figures (Nichols chart, tracking bounds, family responses, zero dynamics).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ...io import dumps_strict
from ...params import BplirParams, ControllerParams
from . import qft as Q
from . import plants as PL
from .control_plots import plot_family_responses, plot_nichols, plot_tracking, plot_zero_dynamics
from ...systems.controller import outer_loop_numerator
from .zero_dynamics import zero_dynamics_portrait


@dataclass
class QftReport:
    """The verification and the data of its figures.

    ``report`` is the JSON-ready summary; ``verification`` the
    :class:`~.qft.Verification` of the plotted family; ``bounds``,
    ``templates``, ``loop`` (nominal L0 on ``w_dense``, rad/s) draw the
    Nichols chart; ``portraits`` the zero dynamics without and with
    friction."""

    report: dict
    family: Any
    verification: Any
    bounds: Any
    templates: np.ndarray
    loop: np.ndarray
    w_dense: np.ndarray
    portraits: list

    def to_dict(self) -> dict:
        """The JSON-ready summary."""
        return self.report

    def to_json(self) -> str:
        """The summary as strict JSON text."""
        return dumps_strict(self.report)

    def figures(self) -> dict:
        """The four figures by file name (new figures; saving is the
        caller's)."""

        return {"nichols.png": plot_nichols(self.bounds, self.templates, self.loop, self.w_dense),
                "tracking_bode.png": plot_tracking(self.verification),
                "family_responses.png": plot_family_responses(self.verification),
                "zero_dynamics.png": plot_zero_dynamics(self.portraits)}

    def plot(self, axes=None):
        """The family's step responses against the specifications."""

        return plot_family_responses(self.verification, axes)


def _published(ctrl: ControllerParams, specs) -> tuple[dict, Any, Any, Any]:
    import control

    fam_nodelay = PL.dissertation_family(td=None)
    fam = PL.dissertation_family()
    d = ctrl.design
    K = control.tf(d["k_num"], d["k_den"])  # as published: negative for (4.16)
    F = control.tf(d["f_num"], d["f_den"])
    v0 = Q.verify(fam_nodelay, K, F, specs)
    vd = Q.verify(fam, K, F, specs)
    dc = [float(np.real(control.dcgain(F * control.feedback(p.tf * K, 1))))
          for p in fam_nodelay.plants]
    report = {"without_delay": v0.summary(),
              "with_delay_0.15_0.3_s": vd.summary(),
              "dc_tracking_band_without_delay": [min(dc), max(dc)],
              "largest_delay_published_K_keeps_stable": Q.max_stable_delay(fam_nodelay, K)}
    return report, fam_nodelay, v0, K


def _from_diagram(params: BplirParams, ctrl: ControllerParams, specs, plants: int, seed: int,
                  design: bool, progress: bool = False) -> tuple[dict, Any, Any, Any]:
    import control


    fam = PL.diagram_family(params, plants, seed=seed)
    d = ctrl.design
    K = control.tf(outer_loop_numerator(ctrl), d["k_den"])
    F = control.tf(d["f_num"], d["f_den"])
    report: dict = {}
    if design:
        des = Q.design_qft(fam, specs, seed=seed, progress=progress)
        K, F = des["K"], des["F"]
        report["design"] = {"K": Q.tf_coefficients(K), "F": Q.tf_coefficients(F),
                            "worst_ratio": des["worst_ratio"], "params": des["params"]}
    ver = Q.verify(fam, K, F, specs)
    report |= {"verification": ver.summary(),
               "v_max_6_19": PL.v_max_over_box(params),
               "largest_delay_K_keeps_stable": Q.max_stable_delay(fam, K)}
    return report, fam, ver, K


def qft_report(params: BplirParams, controller: str | None = None, *,
               family: str = "dissertation", plants: int = 60, seed: int = 0,
               design: bool = False, progress: bool = False) -> QftReport:
    """Verify (and with ``design`` redesign) the outer loop of ``controller``
    (a preset name; default ``params.controller``) on ``family``:
    ``"dissertation"`` (published plants, K as published) or ``"diagram"``
    (``plants`` plants linearised from the simulated diagram with friction
    and masses drawn from ``seed``; K sign-corrected as the controller uses
    it).  ``progress``: the design's generations on standard error."""

    ctrl = ControllerParams.preset_named(controller) if controller else params.controller
    specs = Q.QftSpecs()
    if family == "dissertation":
        body, fam, ver, K = _published(ctrl, specs)
    else:
        body, fam, ver, K = _from_diagram(params, ctrl, specs, plants, seed, design, progress)
    report = {"family": family, "controller": ctrl.preset} | body
    bounds = Q.compute_bounds(fam, specs)
    w_dense = np.logspace(-1, 3, 500)
    P0 = fam.plants[fam.nominal]
    loop = P0(w_dense) * np.asarray(K(1j * w_dense))
    report["nominal_loop_vs_bounds"] = Q.check_loop(
        bounds, P0(bounds.omegas) * np.asarray(K(1j * bounds.omegas)))
    portraits = [zero_dynamics_portrait(params.plant, None),
                 zero_dynamics_portrait(params.plant, params.friction, duration=40.0)]
    return QftReport(report, fam, ver, bounds, Q.templates(fam, bounds.omegas), loop, w_dense,
                     portraits)
