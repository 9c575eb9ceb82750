"""A small Quantitative Feedback Theory (QFT) toolkit on python-control.

No maintained Python QFT toolbox exists; this module computes what the
MATLAB QFT toolbox used in chapter 6 does, as data:

* plant families (:class:`PlantFamily`): transfer functions with optional
  pure delay; the parametric family (4.16) and families obtained by
  linearising the CPFL loop of the diagram (:func:`diagram_family`);
* templates (the family's frequency response at design frequencies);
* specifications (:class:`QftSpecs`): tracking bounds (6.17), robust stability
  ``|1/(1+L)| <= 3 dB`` (6.18), control effort ``|F K/(1+L)| <= 220`` (6.20),
  input-disturbance rejection ``|P/(1+L)|``;
* bounds on the Nichols chart (:func:`compute_bounds`): for every design
  frequency, the set of nominal open-loop values ``L0 = |L0| e^{j phase}`` on
  a phase x magnitude grid for which each specification holds for every
  plant of the template (``L_i = L0 P_i/P_0``);
* checks of a loop against the bounds (:func:`check_loop`), and closed-loop
  verification of every plant in frequency and time (:func:`verify`): step
  tracking, input and output disturbance (Figs 6.10-6.12);
* a loop-shaping design by constrained optimisation (:func:`design_qft`).

Compute functions return data; :mod:`bplir_drake.analysis.control.control_plots` plots it.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import control
import numpy as np
from ...io import Result
from .qft_error import QftError
from .plants import PlantFamily, _check_omegas, _s
from .loops import closed_loops, step_responses
from .control_plots import plot_family_responses
from ...progress import progress_bar


# ----------------------------------------------------------- plants


# ----------------------------------------------------------- specifications


def default_tracking_bounds():
    """(lower, upper) tracking models of (6.17) as transfer functions in s."""
    s = _s()
    lower = 0.9 / ((s / 10) ** 2 + 0.15 * s + 1)
    upper = 1.1 / ((s / 26) ** 2 + 0.077 * s + 1)
    return lower, upper


@dataclass
class QftSpecs:
    """Specifications of 6.3.  ``tracking_lower``/``upper`` are (6.17),
    ``stability_db`` (6.18), ``effort_max`` (6.20) for a unit reference step,
    ``input_disturbance`` bounds ``|P/(1+L)|`` (rad per rad/s^2),
    ``settling_time`` the time by which a unit step stays in the
    ``steady_band``, ``disturbance_settling`` the time by which a unit step
    output disturbance has decayed below ``steady_band``.  The tracking
    bounds apply up to ``tracking_band_max`` (100 rad/s, where the lower
    bound is already below -40 dB); stability and effort apply at all
    frequencies."""

    tracking_lower: control.TransferFunction = None
    tracking_upper: control.TransferFunction = None
    stability_db: float = 3.0
    effort_max: float = 220.0
    input_disturbance: float | None = None
    settling_time: float = 0.39
    steady_band: float = 0.1
    disturbance_settling: float = 0.39
    tracking_band_max: float = 100.0
    omegas: np.ndarray = field(default_factory=lambda: np.array([0.5, 1, 2, 5, 10, 20, 40, 80]))

    def __post_init__(self):
        lo, up = default_tracking_bounds()
        self.tracking_lower = self.tracking_lower if self.tracking_lower is not None else lo
        self.tracking_upper = self.tracking_upper if self.tracking_upper is not None else up
        self.omegas = _check_omegas(self.omegas)
        for name in ("stability_db", "effort_max", "settling_time", "steady_band",
                     "disturbance_settling"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise QftError(f"specification {name} = {v} must be a positive number")
        if self.input_disturbance is not None and not self.input_disturbance > 0:
            raise QftError(f"specification input_disturbance = {self.input_disturbance} must be > 0")
        w = np.logspace(-2, 3, 200)
        if np.any(np.abs(self.tracking_lower(1j * w)) > np.abs(self.tracking_upper(1j * w)) + 1e-12):
            raise QftError("tracking lower bound exceeds the upper bound at some frequency")

    @property
    def stability_max(self) -> float:
        """The stability margin bound |L/(1+L)| <= this, as a ratio (from ``stability_db``)."""
        return 10 ** (self.stability_db / 20)

    def tracking_spread_db(self, w) -> np.ndarray:
        """Allowed spread (dB) of the closed-loop tracking magnitude at frequencies ``w`` (rad/s)."""
        return 20 * np.log10(np.abs(self.tracking_upper(1j * np.asarray(w)))
                             / np.abs(self.tracking_lower(1j * np.asarray(w))))


# ----------------------------------------------------------- templates and bounds

def templates(family: PlantFamily, omegas) -> np.ndarray:
    """(n_w, n_plants) complex values P_i(j w)."""
    return family.response(_check_omegas(omegas)).T


@dataclass
class Bounds:
    """QFT bounds on the Nichols plane: per design frequency (rad/s), a mask of allowed (phase deg,
    gain dB) of the nominal loop for each specification."""
    omegas: np.ndarray
    phases_deg: np.ndarray
    mags_db: np.ndarray
    masks: dict[str, np.ndarray]   # spec -> (n_w, n_phase, n_mag) bool: allowed
    nominal_response: np.ndarray   # P0(j w)

    @property
    def combined(self) -> np.ndarray:
        """The allowed region of every specification at once, (n_w, n_phase, n_mag) bool."""
        out = np.ones_like(next(iter(self.masks.values())))
        for m in self.masks.values():
            out &= m
        return out


def compute_bounds(family: PlantFamily, specs: QftSpecs, omegas=None,
                   phases_deg=None, mags_db=None) -> Bounds:
    """Allowed nominal-loop values per design frequency and specification."""
    w = _check_omegas(specs.omegas if omegas is None else omegas)
    ph = np.arange(-360.0, 0.01, 2.0) if phases_deg is None else np.asarray(phases_deg)
    mg = np.arange(-40.0, 80.01, 0.5) if mags_db is None else np.asarray(mags_db)
    P = templates(family, w)                        # (n_w, n_p)
    P0 = P[:, family.nominal]
    ratio = P / P0[:, None]                         # L_i = L0 * ratio_i
    L0 = (10 ** (mg[None, :] / 20)) * np.exp(1j * np.radians(ph))[:, None]   # (n_ph, n_mg)
    Li = L0[None, :, :, None] * ratio[:, None, None, :]                      # (w, ph, mg, p)
    S = 1.0 / (1.0 + Li)
    masks = {"stability": np.all(np.abs(S) <= specs.stability_max, axis=-1)}
    T = np.abs(Li * S)
    spread = 20 * np.log10(T.max(axis=-1) / np.maximum(T.min(axis=-1), 1e-300))
    masks["tracking"] = spread <= specs.tracking_spread_db(w)[:, None, None]
    if specs.input_disturbance is not None:
        PS = np.abs(P[:, None, None, :] * S)
        masks["input_disturbance"] = np.all(PS <= specs.input_disturbance, axis=-1)
    return Bounds(w, ph, mg, masks, P0)


def check_loop(bounds: Bounds, L0_values) -> dict:
    """Is the nominal loop inside the allowed region at each design
    frequency?  Returns per spec a list of booleans and the worst margin in
    dB (distance in magnitude to the nearest forbidden cell at that phase;
    negative when violated)."""
    L0 = np.asarray(L0_values)
    out = {}
    for name, mask in list(bounds.masks.items()) + [("all", bounds.combined)]:
        ok, margins = [], []
        for k, val in enumerate(L0):
            phase = np.degrees(np.angle(val))
            phase = phase - 360.0 if phase > 0 else phase
            ip = int(np.argmin(np.abs(bounds.phases_deg - phase)))
            mdb = 20 * np.log10(abs(val))
            im = int(np.argmin(np.abs(bounds.mags_db - mdb)))
            row = mask[k, ip]
            ok.append(bool(row[im]))
            bad = np.nonzero(~row)[0]
            if row[im]:
                margins.append(float(np.min(np.abs(bounds.mags_db[bad] - mdb))) if bad.size else math.inf)
            else:
                good = np.nonzero(row)[0]
                margins.append(-float(np.min(np.abs(bounds.mags_db[good] - mdb))) if good.size else -math.inf)
        out[name] = {"inside": ok, "worst_margin_db": min(margins)}
    return out


# ----------------------------------------------------------- verification

@dataclass
class Verification(Result):
    """The closed loops of a family checked against the specifications: one entry per check (worst
    value, limit, holds) and the responses to plot."""
    family: str
    n_plants: int
    checks: dict          # spec -> {"holds": bool, "worst": float, "limit": float, "worst_plant": str}
    responses: dict       # for plotting: t, step outputs, controls, disturbances, bode data

    @property
    def all_hold(self) -> bool:
        """Every specification holds for every plant."""
        return all(c["holds"] for c in self.checks.values())

    def plot(self, axes=None):
        """The family's step and disturbance responses against the specifications (four axes)."""

        return plot_family_responses(self, axes)

    def summary(self) -> dict:
        """The checks and the family as JSON-ready data."""
        return {"family": self.family, "plants": self.n_plants, "all_hold": self.all_hold,
                "specifications": self.checks}


def _settling_time(t, y, final, band, step: float = 1.0) -> float:
    """First time after which ``y`` stays within ``band`` (relative to the
    larger of the final value and the step size) of ``final``."""
    outside = np.abs(y - final) > band * max(abs(final), step)
    if not outside.any():
        return 0.0
    k = int(np.nonzero(outside)[0][-1])
    return float(t[k + 1]) if k + 1 < len(t) else math.inf


def verify(family: PlantFamily, K: control.TransferFunction, F: control.TransferFunction,
           specs: QftSpecs, *, t_final: float = 2.0, n_t: int = 2001,
           pade_order: int = 6) -> Verification:
    """Check every plant of the family in the frequency and the time domain."""
    w = np.logspace(-1, 3, 600)
    lo = np.abs(specs.tracking_lower(1j * w))
    up = np.abs(specs.tracking_upper(1j * w))
    Kw, Fw = np.asarray(K(1j * w)), np.asarray(F(1j * w))
    t = np.linspace(0, t_final, n_t)
    rec = {k: [] for k in ("stable", "S_peak", "track_margin_db", "effort_peak_freq", "PS_peak",
                           "steady_error", "settling", "effort_peak_time", "out_dist_settling",
                           "in_dist_peak")}
    resp = {"t": t, "w": w, "step": [], "u": [], "in_dist": [], "out_dist": [], "TF_mag": [],
            "labels": [], "bounds": (lo, up)}
    for pl in family.plants:
        Pw = pl(w)
        Lw = Pw * Kw
        Sw = 1 / (1 + Lw)
        TFw = Fw * Lw * Sw
        rec["S_peak"].append(float(np.abs(Sw).max()))
        m = np.abs(TFw)
        band = w <= specs.tracking_band_max
        rec["track_margin_db"].append(float(min(
            np.min(20 * np.log10(up / np.maximum(m, 1e-300))[band]),
            np.min(20 * np.log10(np.maximum(m, 1e-300) / lo)[band]))))
        rec["effort_peak_freq"].append(float(np.abs(Fw * Kw * Sw).max()))
        rec["PS_peak"].append(float(np.abs(Pw * Sw).max()))
        resp["TF_mag"].append(m)
        resp["labels"].append(pl.label)
        G = pl.rational(pade_order)
        L, S, T, TF, U, PS = closed_loops(G, K, F)
        poles = np.linalg.eigvals(np.asarray(T.A)) if T.nstates else np.zeros(0)
        stable = bool(np.all(poles.real < 0))
        rec["stable"].append(stable)
        if not stable:
            for key in ("steady_error", "settling", "effort_peak_time", "out_dist_settling",
                        "in_dist_peak"):
                rec[key].append(math.inf)
            for key in ("step", "u", "in_dist", "out_dist"):
                resp[key].append(np.full_like(t, np.nan))
            continue
        y, u, yd, yo = step_responses((TF, U, PS, S), t)
        final = float(np.real(control.dcgain(TF)))
        rec["steady_error"].append(abs(final - 1.0))
        rec["settling"].append(_settling_time(t, y, 1.0, specs.steady_band))
        rec["effort_peak_time"].append(float(np.abs(u).max()))
        rec["out_dist_settling"].append(_settling_time(t, yo, 0.0, specs.steady_band))
        rec["in_dist_peak"].append(float(np.abs(yd).max()))
        for key, val in (("step", y), ("u", u), ("in_dist", yd), ("out_dist", yo)):
            resp[key].append(np.asarray(val))
    labels = [p.label for p in family.plants]

    def worst(key, mode, limit):
        vals = np.asarray(rec[key], dtype=float)
        i = int(np.argmax(vals) if mode == "max" else np.argmin(vals))
        v = float(vals[i])
        holds = bool(v <= limit) if mode == "max" else bool(v >= limit)
        return {"holds": holds, "worst": v, "limit": limit, "worst_plant": labels[i]}

    checks = {
        "closed_loop_stable": {"holds": all(rec["stable"]),
                               "worst": int(sum(not s for s in rec["stable"])), "limit": 0,
                               "worst_plant": next((labels[i] for i, s in enumerate(rec["stable"])
                                                    if not s), "")},
        "robust_stability_6_18": worst("S_peak", "max", specs.stability_max),
        "tracking_6_17_freq_margin_db": worst("track_margin_db", "min", 0.0),
        "effort_6_20_freq": worst("effort_peak_freq", "max", specs.effort_max),
        "steady_state_error": worst("steady_error", "max", specs.steady_band),
        "settling_time_s": worst("settling", "max", specs.settling_time),
        "effort_6_20_time": worst("effort_peak_time", "max", specs.effort_max),
        "output_disturbance_settling_s": worst("out_dist_settling", "max", specs.disturbance_settling),
    }
    if specs.input_disturbance is not None:
        checks["input_disturbance_peak"] = worst("in_dist_peak", "max", specs.input_disturbance)
    else:
        checks["input_disturbance_peak"] = worst("in_dist_peak", "max", math.inf)
    return Verification(family.name, len(family), checks, resp)


def delay_margin(plant_tf: control.TransferFunction, K: control.TransferFunction) -> float:
    """Largest pure delay the loop ``K P`` tolerates (phase margin / crossover),
    over all gain crossovers; 0 when unstable without delay, inf without
    crossover."""
    w = np.logspace(-2, 4, 20000)
    L = np.asarray((plant_tf * K)(1j * w))
    T = control.feedback(plant_tf * K, 1)
    if np.any(control.poles(T).real >= 0):
        return 0.0
    mag = np.abs(L)
    cross = np.nonzero(np.diff(np.sign(mag - 1.0)) != 0)[0]
    if cross.size == 0:
        return math.inf
    dms = []
    for k in cross:
        wc = w[k]
        pm = (np.angle(L[k]) + math.pi) % (2 * math.pi)
        dms.append(pm / wc)
    return float(min(dms))


def max_stable_delay(family: PlantFamily, K: control.TransferFunction) -> dict:
    """Delay margin of each plant (its own delay removed) and the family minimum."""
    dm = [delay_margin(p.tf, K) for p in family.plants]
    i = int(np.argmin(dm))
    return {"largest_delay_all_plants_s": float(dm[i]), "limiting_plant": family.plants[i].label,
            "per_plant_s": [float(x) for x in dm]}


# ----------------------------------------------------------- design

def lead_pid(k, zi, z, p):
    """``K(s) = k (s + zi)(s + z) / (s (s/p + 1))``: integral + lead."""
    return control.tf([k, k * (zi + z), k * zi * z], [1.0 / p, 1.0, 0.0])


def second_order_prefilter(wf, zeta, gain=1.0):
    """F(s) = gain wf^2 / (s^2 + 2 zeta wf s + wf^2), ``wf`` in rad/s."""
    return control.tf([gain * wf ** 2], [1.0, 2 * zeta * wf, wf ** 2])


#: search box of :func:`design_qft`: k, zi, z, p (rad/s), wf, zeta_f, F gain
DESIGN_BOUNDS = ((1.0, 300.0), (0.3, 20.0), (1.0, 60.0), (10.0, 250.0),
                 (2.0, 60.0), (0.4, 2.0), (0.8, 1.25))


def spec_violation(family: PlantFamily, specs: QftSpecs, K, F, w=None,
                   crossover_max: float | None = None) -> dict:
    """Ratios to the limits on a frequency grid (<= 1: the spec holds for
    every plant): robust stability (6.18), tracking (6.17) inside the
    tracking band, effort (6.20), and (optional) the nominal loop crossing
    over below ``crossover_max``."""
    w = np.logspace(-1, 4, 400) if w is None else w
    P = family.response(w)
    Kw, Fw = np.asarray(K(1j * w)), np.asarray(F(1j * w))
    return _violation(P, Kw, Fw, w, specs, crossover_max)


def _violation(P, Kw, Fw, w, specs, crossover_max):
    L = P * Kw
    S = 1 / (1 + L)
    TF = np.abs(Fw * L * S)
    band = w <= specs.tracking_band_max
    lo = np.abs(specs.tracking_lower(1j * w[band]))
    up = np.abs(specs.tracking_upper(1j * w[band]))
    out = {"stability": float(np.abs(S).max() / specs.stability_max),
           "tracking": float(max(np.max(TF[:, band] / up), np.max(lo / TF[:, band]))),
           "effort": float(np.abs(Fw * Kw * S).max() / specs.effort_max)}
    if crossover_max is not None:
        out["crossover"] = float(np.max(np.abs(L[0])[w >= crossover_max]))
    return out


def design_qft(family: PlantFamily, specs: QftSpecs, *, crossover_max: float = 25.0,
               seed: int = 0, maxiter: int = 300, progress: bool = False) -> dict:
    """Loop shaping as a min-max problem, solved by differential evolution:
    the integral + lead ``K`` (:func:`lead_pid`) and second-order prefilter
    ``F`` minimising the worst ratio of every plant's response to the bounds
    (6.17), (6.18), (6.20), with the nominal loop crossing over below
    ``crossover_max`` (well below the Nyquist frequency pi/Ts, where the
    half-sample delay model of the zero-order hold holds).  A result below 1
    meets every specification on the frequency grid.  ``progress``: the
    generations (at most ``maxiter``) and the best worst ratio so far, on
    standard error."""
    from scipy.optimize import differential_evolution


    w = np.logspace(-1, 4, 400)
    P = family.response(w)
    s = 1j * w

    def build(x):
        k, zi, z, p, wf, zf, g = np.exp(x)
        return k * (s + zi) * (s + z) / (s * (s / p + 1)), g * wf ** 2 / (s ** 2 + 2 * zf * wf * s + wf ** 2)

    def cost(x):
        Kw, Fw = build(x)
        return max(_violation(P, Kw, Fw, w, specs, crossover_max).values())

    with progress_bar(progress, desc="QFT design", unit="generations", total=maxiter) as bar:
        def generation(intermediate_result):
            bar.update()
            bar.set_postfix_str(f"worst ratio {intermediate_result.fun:.3f}")

        res = differential_evolution(cost, [(math.log(a), math.log(b)) for a, b in DESIGN_BOUNDS],
                                     seed=seed, maxiter=maxiter, popsize=20, tol=1e-10,
                                     polish=True, callback=generation if progress else None)
    k, zi, z, p, wf, zf, g = np.exp(res.x)
    K, F = lead_pid(k, zi, z, p), second_order_prefilter(wf, zf, g)
    return {"K": K, "F": F, "worst_ratio": float(res.fun),
            "violation": spec_violation(family, specs, K, F, w, crossover_max),
            "params": {"k": k, "zi": zi, "z": z, "p": p, "wf": wf, "zeta_f": zf, "f_gain": g}}


def tf_coefficients(sys: control.TransferFunction) -> tuple[tuple, tuple]:
    """(numerator, denominator) coefficients of a SISO transfer function, highest power first."""
    num = np.atleast_1d(np.squeeze(sys.num[0][0]))
    den = np.atleast_1d(np.squeeze(sys.den[0][0]))
    return tuple(float(c) for c in num), tuple(float(c) for c in den)


# ----------------------------------------------------------- the diagram's family


