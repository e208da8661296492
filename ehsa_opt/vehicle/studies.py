"""The paper's §4.1 quarter-car studies (Figs 13–16) and Fig 21, as functions.

Each study returns a small result object (with ``.plot()`` delegating to
:mod:`ehsa_opt.plots.quarter_car`).  All heavy lifting is the compiled batch
simulation of :mod:`ehsa_opt.vehicle.simulate` (designs × friction cases in one call).

Friction cases (:func:`friction_cases`): "none", "min", "max".  They come from
the identification results when given (``friction_min`` / ``friction_max``
mappings of the eight friction names); otherwise, until identification lands,
"max" is the embedded bench data set's true friction and "min" that friction
scaled by 0.3 (forces, torques and viscous coefficients; breakaway velocities
kept) — labelled as such in every output.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Sequence

import numpy as np
from scipy import signal

from ..datasets.embedded import embedded_data_dir, load_truth
from ..datasets.friction_source import FrictionSets
from ..physics.bench_model import BenchModel
from ..physics.bench_sim import simulate_bench
from ..physics.motion import SineMotion
from ..physics.params import (FrictionParams, HarvesterParams, ParameterError,
                              RoadParams, VehicleParams)
from ..physics.friction import rod_friction_N
from ..physics.quarter_car_model import PARAM_NAMES, STATE_NAMES, param_vector
from .coverage import OUT_OF_RANGE_LIMIT
from .frequency_path import linear_frequency_response
from .road import road_psd_m3
from .simulate import QuarterCarSimulation, simulate_batch, simulate_quarter_car

__all__ = ["FrictionCases", "friction_cases", "paper_optimum_harvester",
           "FrequencyResponseStudy", "stepped_sine_response", "ForceVelocityStudy",
           "force_velocity_loops", "RoadStudy", "road_study", "equivalent_damping_slope",
           "MIN_FRICTION_SCALE", "WELCH_SEGMENTS", "welch_segment_length"]


#: Scale of the "min" friction when identification results are absent.
MIN_FRICTION_SCALE = 0.3


@dataclass(frozen=True)
class FrictionCases:
    """No / min / max friction and where they come from."""

    cases: dict[str, FrictionParams | None]
    source: str


def friction_cases(identification: FrictionSets | None = None,
                   method: str = "data") -> FrictionCases:
    """The study's friction cases.

    Parameters
    ----------
    identification : FrictionSets, optional
        The identified sets (:class:`~ehsa_opt.datasets.friction_source.FrictionSets`, as
        the identification step gives them): ``min`` and ``max`` are the data-supported
        sets of :mod:`ehsa_opt.estimation.bounds`.  None: the embedded data set's true
        friction as ``max`` and a scaled copy as ``min``, labelled so.
    method : {"data", "paper"}
        "paper": the per-parameter min/max over the tests (``paper_min`` /
        ``paper_max``), the paper's method, which over-states the spread.
    """
    if method not in ("data", "paper"):
        raise ValueError(f"friction_cases: method must be 'data' or 'paper', got {method!r}")
    if identification is not None and (method == "data"
                                       or identification.paper_min is not None):
        lo, hi = identification.bounds(method)
        label = ("identified, data-supported: ordered sets min <= best <= max at every "
                 "velocity, enclosing the tests' envelope and beyond the bench the best law's "
                 "95 % band (ehsa_opt.estimation.bounds)"
                 if method == "data" else
                 "identified, paper's method: per-parameter min/max over the bench tests")
        return FrictionCases({"none": None, "min": lo, "max": hi}, label)
    truth = FrictionParams(**load_truth(embedded_data_dir())["friction"])
    scaled = {k: (v if "velocity" in k else MIN_FRICTION_SCALE * v)
              for k, v in truth.as_dict().items()}
    return FrictionCases({"none": None, "min": FrictionParams(**scaled), "max": truth},
                         "embedded data set's TRUE friction as 'max' and "
                         f"×{MIN_FRICTION_SCALE} of it as 'min' (identification not available)")


def paper_optimum_harvester() -> HarvesterParams:
    """The paper's goal-attainment optimum (§4.2): J_t = 250 g cm², k_n = 29.8 rpm/V,
    p = 7 mm/rev, R_e = 75 Ω (the design the paper's Fig 21 uses)."""
    return HarvesterParams.from_design(250.0, 7.0, 29.8, 75.0)


def _fundamental(sig: np.ndarray, t: np.ndarray, f: float, harmonics: int = 3) -> np.ndarray:
    """Amplitude of the component at ``f`` (last axis) by least squares on a constant,
    the fundamental and ``harmonics - 1`` higher harmonics, so a window that is whole
    cycles only up to one time step (or carries friction's odd harmonics) leaks nothing
    measurable into the fundamental."""
    w = 2.0 * math.pi * f * (t - t[0])
    cols = [np.ones_like(w)]
    for k in range(1, harmonics + 1):
        cols += [np.cos(k * w), np.sin(k * w)]
    basis = np.stack(cols, axis=1)
    coef, *_ = np.linalg.lstsq(basis, sig.reshape(-1, sig.shape[-1]).T, rcond=None)
    amp = np.hypot(coef[1], coef[2])
    return amp.reshape(sig.shape[:-1])


# --------------------------------------------------------------------------- Fig 13
@dataclass
class FrequencyResponseStudy:
    """Stepped-sine steady-state responses (paper Fig 13).

    Attributes
    ----------
    frequencies_hz : ndarray (F,)
    loads_ohm : list of float (L,)
    cases : list of str (C,)
    voltage_amplitude_V : ndarray (C, L, F)
        Fundamental amplitude of the generator voltage V_g = R_e i at steady state.
    sprung_transmissibility : ndarray (C, L, F)
        Fundamental amplitude of x2 divided by the road amplitude at steady state.
    amplitude_m : float
        Road sine amplitude (constant-displacement input), or the amplitude at 1 Hz of a
        constant-velocity input.
    settled : ndarray of bool (C, L, F)
        Whether both amplitudes changed by less than ``tolerance`` (relative) between the
        last two measurement windows; a point that did not settle within ``max_time_s``
        is False and must be flagged where it is shown.
    amplitude_change : ndarray (C, L, F)
        That last relative change (the larger of x2 and V_g).
    linear_voltage_amplitude_V, linear_transmissibility : ndarray (L, F)
        The exact frictionless responses (:func:`~ehsa_opt.vehicle.frequency_path.linear_frequency_response`),
        the check of the simulation: the case "none" must match them.
    tolerance : float
        The settling tolerance on the window-to-window amplitude change.
    velocity_amplitude_m_per_s : float or None
        Road velocity amplitude of a constant-velocity input (displacement
        v / (2π f), falling with frequency like a real road); None = constant displacement.
    identified_range_m_per_s : float or None
        The friction's identified range the fractions below are measured against.
    out_of_range_time_fraction, out_of_range_friction_energy_fraction : ndarray (C, L, F)
        Share of the last (steady) window's time, and of the friction's dissipated energy,
        at stroke velocities above the identified range (NaN energy without friction);
        None when no range was given.
    peak_stroke_m : ndarray (C, L, F)
        Largest stroke |x2 − x1| of the last (steady) window; checked against the
        vehicle's ``stroke_limit_m`` by :meth:`beyond_stroke_limit`.
    """

    frequencies_hz: np.ndarray
    loads_ohm: list[float]
    cases: list[str]
    voltage_amplitude_V: np.ndarray
    sprung_transmissibility: np.ndarray
    amplitude_m: float
    friction_source: str
    vehicle: VehicleParams
    stats: dict = field(default_factory=dict)
    velocity_amplitude_m_per_s: float | None = None
    settled: np.ndarray | None = None
    amplitude_change: np.ndarray | None = None
    linear_voltage_amplitude_V: np.ndarray | None = None
    linear_transmissibility: np.ndarray | None = None
    tolerance: float = 1e-3
    identified_range_m_per_s: float | None = None
    out_of_range_time_fraction: np.ndarray | None = None
    out_of_range_friction_energy_fraction: np.ndarray | None = None
    out_of_range_limit: float = OUT_OF_RANGE_LIMIT
    peak_stroke_m: np.ndarray | None = None

    @property
    def stroke_limit_m(self) -> float:
        """The vehicle's stroke limit, m."""
        return float(self.vehicle.stroke_limit_m)

    def beyond_stroke_limit(self) -> np.ndarray:
        """(C, L, F) bool: points whose steady peak stroke |x2 − x1| exceeds the vehicle's
        limit (the suspension would hit its bump stops, which the model does not have)."""
        if self.peak_stroke_m is None:
            return np.zeros(self.voltage_amplitude_V.shape, bool)
        return self.peak_stroke_m > self.stroke_limit_m

    def frictionless_deviation(self) -> float:
        """Largest relative deviation of the case "none" from the exact linear response
        over every frequency, load and both outputs (nan without a case "none")."""
        if "none" not in self.cases or self.linear_transmissibility is None:
            return float("nan")
        i = self.cases.index("none")
        dv = np.abs(self.voltage_amplitude_V[i] / self.linear_voltage_amplitude_V - 1.0)
        dx = np.abs(self.sprung_transmissibility[i] / self.linear_transmissibility - 1.0)
        return float(max(np.max(dv), np.max(dx)))

    def plot(self, ax: Any = None) -> Any:
        """Paper Fig 13 (two panels; ``ax`` not used); writes nothing."""
        from ..plots.quarter_car import fig13_frequency_response
        return fig13_frequency_response(self)


def _steady_start(vehicle: VehicleParams, harvester: HarvesterParams, loads: Sequence[float],
                  f: float, amp: float) -> np.ndarray:
    """States (6, L) at t = 0 of the exact frictionless steady state under
    x0 = amp sin(2π f t): x = amp Im(H), ẋ = amp ω Re(H), i = amp Im(H_i); the bristle
    force (LuGre) at rest."""
    w = 2.0 * math.pi * f
    z = np.zeros((len(STATE_NAMES), len(loads)))
    for j, r in enumerate(loads):
        lin = linear_frequency_response(vehicle, harvester.replace(load_ohm=float(r)), [f])
        x2, x1, cur = lin["x2"][0], lin["x1"][0], lin["current"][0]
        z[:5, j] = amp * np.array([x2.imag, x1.imag, w * x2.real, w * x1.real, cur.imag])
    return z


def stepped_sine_response(vehicle: VehicleParams, harvester: HarvesterParams,
                          frictions: FrictionCases, loads_ohm: Sequence[float],
                          frequencies_hz: Sequence[float], amplitude_m: float = 0.01,
                          sample_rate_hz: float = 1000.0, tolerance: float = 1e-3,
                          window_min_s: float = 1.0, max_time_s: float = 60.0,
                          velocity_amplitude_m_per_s: float | None = None,
                          identified_range_m_per_s: float | None = None
                          ) -> FrequencyResponseStudy:
    """Steady-state generator voltage and sprung-mass displacement vs road sine frequency.

    With ``velocity_amplitude_m_per_s`` the road is a sine of constant *velocity*
    amplitude (displacement v / (2π f): it falls with frequency like a road's, ISO 8608
    slope −1 in velocity terms flat), so the voltages stay physical at high frequency;
    otherwise the displacement amplitude is ``amplitude_m`` at every frequency.

    Steady state by construction.  For each frequency one compiled batch simulates every
    (friction case, load) pair, starting from the *exact* frictionless steady state
    (:func:`~ehsa_opt.vehicle.frequency_path.linear_frequency_response`; with friction this is
    the best linear guess, and only the friction's correction is a transient).  The
    simulation runs in windows of whole cycles lasting at least ``window_min_s``, the
    fundamental amplitudes of x2 and V_g are measured in each window (least squares), and
    it stops when every pair's amplitudes change by less than ``tolerance`` (relative)
    from one window to the next, or at ``max_time_s`` (the pairs that have not settled
    are marked in :attr:`FrequencyResponseStudy.settled`).  Friction makes the system
    nonlinear, hence simulation; without friction the result is checked against the
    exact response (:meth:`FrequencyResponseStudy.frictionless_deviation`).

    With ``identified_range_m_per_s`` every point also states the share of its last
    window's time and of the friction's dissipated energy at stroke velocities above that
    range (:func:`~ehsa_opt.vehicle.coverage.series_coverage`).
    """
    if not 0.0 < tolerance < 0.1:
        raise ParameterError(f"stepped sine: tolerance = {tolerance:g} must be in (0, 0.1) "
                             "(a relative change of the amplitude between windows)")
    cases = list(frictions.cases)
    loads = [float(r) for r in loads_ohm]
    pairs = [(c, r) for c in cases for r in loads]
    params = np.stack([param_vector(vehicle, harvester.replace(load_ohm=r),
                                    frictions.cases[c]) for c, r in pairs], axis=1)
    freqs = np.asarray(frequencies_hz, dtype=float)
    shape = (len(cases), len(loads), freqs.size)
    volt, trans = np.empty(shape), np.empty(shape)
    settled, change = np.zeros(shape, dtype=bool), np.empty(shape)
    lin_v, lin_x = np.empty(shape[1:]), np.empty(shape[1:])
    h = 1.0 / sample_rate_hz
    steps, sim_time = 0, []
    re = params[PARAM_NAMES.index("load_ohm")]
    i_x2, i_cur = STATE_NAMES.index("x2_m"), STATE_NAMES.index("current_A")
    i_v2, i_v1 = STATE_NAMES.index("v2_m_per_s"), STATE_NAMES.index("v1_m_per_s")
    oor_t, oor_e = np.full(shape, np.nan), np.full(shape, np.nan)
    stroke = np.full((len(pairs), freqs.size), np.nan)
    pair_fr = [frictions.cases[c] for c, _ in pairs]
    lead = float(harvester.lead_m_per_rad)
    for k, f in enumerate(freqs):
        amp = (amplitude_m if velocity_amplitude_m_per_s is None
               else velocity_amplitude_m_per_s / (2.0 * math.pi * f))
        for j, r in enumerate(loads):
            lin = linear_frequency_response(vehicle, harvester.replace(load_ohm=r), [f])
            lin_v[j, k], lin_x[j, k] = abs(lin["voltage"][0]) * amp, abs(lin["x2"][0])
        z = np.tile(_steady_start(vehicle, harvester, loads, f, amp), (1, len(cases)))
        n_win = int(round(math.ceil(window_min_s * f - 1e-9) / f * sample_rate_hz))
        # per pair: last amplitudes (x2/x0, V_g), last change; settled pairs stop
        last = np.full((2, len(pairs)), np.nan)
        rel = np.full(len(pairs), np.inf)
        active = np.arange(len(pairs))
        t0 = 0.0
        while active.size and t0 < max_time_s:
            t = t0 + np.arange(n_win + 1) * h
            zt, _, _ = simulate_batch(params[:, active], amp * np.sin(2.0 * math.pi * f * t),
                                      h, z0=z[:, active])
            steps += n_win * active.size
            z[:, active] = zt[:, :, -1].T
            tt = t[1:]
            cur = np.stack([_fundamental(zt[:, i_x2], tt, f) / amp,
                            _fundamental(re[active, None] * zt[:, i_cur], tt, f)])
            if t0 > 0.0:
                rel[active] = np.max(np.abs(cur - last[:, active])
                                     / np.maximum(np.abs(cur), 1e-300), axis=0)
            last[:, active] = cur
            stroke[active, k] = np.max(np.abs(zt[:, i_x2] - zt[:, STATE_NAMES.index("x1_m")]),
                                       axis=-1)
            if identified_range_m_per_s is not None:
                _window_coverage(zt[:, i_v2] - zt[:, i_v1], [pair_fr[q] for q in active],
                                 lead, float(identified_range_m_per_s), active, oor_t[..., k],
                                 oor_e[..., k], len(loads))
            t0 = float(t[-1])
            active = active[~(rel[active] < tolerance)]
        trans[:, :, k] = last[0].reshape(len(cases), len(loads))
        volt[:, :, k] = last[1].reshape(len(cases), len(loads))
        settled[:, :, k] = (rel < tolerance).reshape(len(cases), len(loads))
        change[:, :, k] = rel.reshape(len(cases), len(loads))
        sim_time.append(t0)
    a_ref = (amplitude_m if velocity_amplitude_m_per_s is None
             else velocity_amplitude_m_per_s / (2.0 * math.pi))
    return FrequencyResponseStudy(freqs, loads, cases, volt, trans, a_ref, frictions.source,
                                  vehicle, {"step_designs": steps,
                                            "simulated_s_per_frequency": sim_time},
                                  velocity_amplitude_m_per_s, settled, change, lin_v, lin_x,
                                  float(tolerance), identified_range_m_per_s,
                                  None if identified_range_m_per_s is None else oor_t,
                                  None if identified_range_m_per_s is None else oor_e,
                                  peak_stroke_m=stroke.reshape(shape))


def _window_coverage(v_stroke: np.ndarray, frictions: Sequence[FrictionParams | None],
                     lead: float, v_max: float, active: np.ndarray, out_t: np.ndarray,
                     out_e: np.ndarray, n_loads: int) -> None:
    """Out-of-range fractions of one window's stroke velocities (active pairs × samples)
    into ``out_t`` / ``out_e`` (cases × loads views at one frequency)."""
    from .coverage import series_coverage
    for row, (q, fr) in enumerate(zip(active, frictions)):
        v = v_stroke[row]
        power = None if fr is None else np.asarray(
            rod_friction_N(np.abs(v), fr.as_array(), lead), dtype=float) * np.abs(v)
        c = series_coverage(v[None], v_max, None if power is None else power[None])
        out_t[q // n_loads, q % n_loads] = float(c["time_fraction"][0])
        out_e[q // n_loads, q % n_loads] = float(c["energy_fraction"][0])


# --------------------------------------------------------------------------- Fig 14
@dataclass
class ForceVelocityStudy:
    """Force–velocity loops of the harvester (paper Fig 14).

    Attributes
    ----------
    loops : dict
        ``(circuit, case) -> (velocity m/s, force N)`` over one steady cycle.
    equivalent_damping_Ns_per_m : dict
        ``(circuit, case) -> c_eq = ∮F dx / (π ω A²)`` (energy-equivalent).
    identified_range_m_per_s : float or None
    out_of_range : dict
        ``(circuit, case) -> (time, friction energy)`` shares of the steady cycle at
        stroke velocities above the identified range (empty without a range).
    """

    loops: dict[tuple[str, str], tuple[np.ndarray, np.ndarray]]
    equivalent_damping_Ns_per_m: dict[tuple[str, str], float]
    amplitude_m: float
    frequency_hz: float
    friction_source: str
    identified_range_m_per_s: float | None = None
    out_of_range: dict[tuple[str, str], tuple[float, float]] = field(default_factory=dict)
    out_of_range_limit: float = OUT_OF_RANGE_LIMIT

    def plot(self, ax: Any = None) -> Any:
        """Paper Fig 14 (two panels; ``ax`` not used); writes nothing."""
        from ..plots.quarter_car import fig14_force_velocity
        return fig14_force_velocity(self)


def force_velocity_loops(harvester: HarvesterParams, frictions: FrictionCases,
                         amplitude_m: float = 0.015, frequency_hz: float = 1.5,
                         samples_per_cycle: int = 400,
                         identified_range_m_per_s: float | None = None) -> ForceVelocityStudy:
    """Bench-like sine stroke of the harvester, open (R_e → ∞) and short circuit (R_e = 0).

    Uses the rigid :class:`~ehsa_opt.physics.bench_model.BenchModel` (same harvester
    physics as the quarter car).  Open circuit is R_e = 10⁹ Ω (i ≈ 0).  With
    ``identified_range_m_per_s`` every loop states its share of time and friction energy
    above that range (:func:`~ehsa_opt.vehicle.coverage.series_coverage`).
    """
    from .coverage import series_coverage
    model = BenchModel(harvester)
    loops, ceq, oor = {}, {}, {}
    w = 2.0 * math.pi * frequency_hz
    t = np.linspace(0.0, 2.0 / frequency_hz, 2 * samples_per_cycle + 1)
    motion = SineMotion(amplitude_m, frequency_hz)
    for circuit, load in (("open circuit", 1e9), ("short circuit", 0.0)):
        for case in ("min", "max"):
            p = model.param_vector(load, frictions.cases[case])
            sim = simulate_bench(model, motion, p, t)
            sl = slice(samples_per_cycle, None)  # second cycle (steady)
            v, f, x = sim.velocity_m_per_s[sl], sim.force_N[sl], sim.displacement_m[sl]
            work = float(np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(x)))
            loops[(circuit, case)] = (v, f)
            ceq[(circuit, case)] = work / (math.pi * w * amplitude_m ** 2)
            if identified_range_m_per_s is not None:
                power = np.asarray(rod_friction_N(np.abs(v), frictions.cases[case].as_array(),
                                                  harvester.lead_m_per_rad)) * np.abs(v)
                c = series_coverage(v[None], identified_range_m_per_s, power[None])
                oor[(circuit, case)] = (float(c["time_fraction"][0]),
                                        float(c["energy_fraction"][0]))
    return ForceVelocityStudy(loops, ceq, amplitude_m, frequency_hz, frictions.source,
                              identified_range_m_per_s, oor)


# --------------------------------------------------------------------------- Figs 15/16/21
#: Series :func:`equivalent_damping_slope` needs (``keep_series`` of the simulation).
_SLOPE_SERIES = ("damper_force_N", "stroke_velocity_m_s")


def equivalent_damping_slope(sim: QuarterCarSimulation) -> np.ndarray:
    """Least-squares slope through the origin of the non-inertial damper force vs
    stroke velocity, Σ F v / Σ v² (N s/m), per design: the 'damping slope'."""
    f = sim.series["damper_force_N"]
    v = sim.series["stroke_velocity_m_s"]
    return np.sum(f * v, axis=1) / np.sum(v * v, axis=1)


@dataclass
class RoadStudy:
    """Road simulation per friction case (paper Figs 15/16, 21).

    Attributes
    ----------
    sim : QuarterCarSimulation
        One design per case (order of ``cases``), series kept.
    cases : list of str
    loads_ohm : list of float
        Load per case (re-tuned when ``retuned``).
    slopes_Ns_per_m : ndarray
        Equivalent damping slope per case.
    target_slope_Ns_per_m : float or None
    reachable : list of bool
        Whether the re-tuning reached the target slope.
    road_psd : dict
        ``n_cycles_per_m``, ``synth_m3`` (Welch estimate), ``target_m3``, ``segments``,
        ``nperseg`` and ``resolution`` (cycles/m).
    stroke_velocity_psd : dict
        ``f_hz`` and per-case PSD, (m/s)²/Hz, ``segments``, ``nperseg``,
        ``resolution_hz``.
    intervals : RoadIntervals or None
        The cases' metrics on road realisations (:mod:`ehsa_opt.vehicle.uncertainty`),
        when asked for.
    identified_range_m_per_s : float or None
        The friction's identified range (shaded in the force–velocity panel).
    """

    sim: QuarterCarSimulation
    cases: list[str]
    loads_ohm: list[float]
    slopes_Ns_per_m: np.ndarray
    target_slope_Ns_per_m: float | None
    reachable: list[bool]
    road_psd: dict
    stroke_velocity_psd: dict
    friction_source: str
    title: str = ""
    intervals: Any = None
    identified_range_m_per_s: float | None = None
    sample_limits: Any = None

    @property
    def average_power_W(self) -> np.ndarray:
        return self.sim.metrics["power_W"]

    def power_drop_percent(self) -> dict[str, float]:
        """Average power change of each case against 'none', %."""
        p = self.average_power_W
        ref = p[self.cases.index("none")]
        return {c: 100.0 * (p[i] / ref - 1.0) for i, c in enumerate(self.cases)}

    def plot(self, ax: Any = None) -> Any:
        """Paper Figs 15/16 (six panels; ``ax`` not used); writes nothing."""
        from ..plots.quarter_car import fig15_road_study
        return fig15_road_study(self)

    def plot_power(self, ax: Any = None) -> Any:
        """Paper Fig 21, into ``ax`` when given; writes nothing."""
        from ..plots.quarter_car import fig21_power_history
        return fig21_power_history(self, ax=ax)


def road_study(vehicle: VehicleParams, harvester: HarvesterParams, frictions: FrictionCases,
               road: RoadParams, *, retune: bool = True, n_loads: int = 24,
               max_load_factor: float = 200.0, settle_s: float = 2.0,
               sample_rate_hz: float = 1000.0, title: str = "",
               identified_range_m_per_s: float | None = None,
               n_seeds: int | None = None, sample_limits: Any = None) -> RoadStudy:
    """Simulate each friction case on ``road``; optionally re-tune R_e per case.
    ``identified_range_m_per_s``: the final simulation's metrics then hold the fractions
    above the friction's identified range (:mod:`ehsa_opt.vehicle.coverage`).
    ``n_seeds``: the final designs are also simulated on that many Gaussian road
    realisations of the same length (:func:`~ehsa_opt.vehicle.uncertainty.road_intervals`),
    the metrics' 95 % intervals.  ``sample_limits``: the hardware limits the shares of
    time beyond them are measured against
    (:class:`~ehsa_opt.vehicle.validity.SampleLimits`).

    The PSDs are Welch estimates with :data:`WELCH_SEGMENTS` Hann segments overlapping
    by half (the segment length follows from the record's length).

    Re-tuning (paper Figs 15/16): the frictionless case keeps ``harvester.load_ohm``
    and sets the target damping slope (:func:`equivalent_damping_slope`); each
    friction case evaluates ``n_loads`` loads from that value up to
    ``max_load_factor`` times it in one batch and interpolates (log R_e) to the
    load whose slope matches.  If friction alone already exceeds the target the
    largest load is used and ``reachable`` is False.
    """
    cases = list(frictions.cases)
    r0 = harvester.load_ohm
    loads = {c: r0 for c in cases}
    reachable = [True] * len(cases)
    target = None
    if retune:
        grid = np.geomspace(r0, r0 * max_load_factor, n_loads)
        hs, fs_ = [harvester], [None]
        for c in cases:
            if frictions.cases[c] is None:
                continue
            hs += [harvester.replace(load_ohm=float(r)) for r in grid]
            fs_ += [frictions.cases[c]] * n_loads
        scan = simulate_quarter_car(vehicle, hs, [f or FrictionParams() for f in fs_], road,
                                    settle_s=settle_s, sample_rate_hz=sample_rate_hz,
                                    warn=False, keep_series=_SLOPE_SERIES)
        slopes = equivalent_damping_slope(scan)
        target = float(slopes[0])
        j = 1
        for i, c in enumerate(cases):
            if frictions.cases[c] is None:
                continue
            s = slopes[j:j + n_loads]  # decreasing with the load
            j += n_loads
            if s[-1] > target:
                loads[c], reachable[i] = float(grid[-1]), False
            elif s[0] < target:
                loads[c] = float(grid[0])
            else:
                k = int(np.flatnonzero(s <= target)[0])
                x0_, x1_ = math.log(grid[k - 1]), math.log(grid[k])
                frac = (s[k - 1] - target) / (s[k - 1] - s[k])
                loads[c] = float(math.exp(x0_ + frac * (x1_ - x0_)))
    hs = [harvester.replace(load_ohm=loads[c]) for c in cases]
    fr = [frictions.cases[c] or FrictionParams() for c in cases]
    sim = simulate_quarter_car(vehicle, hs, fr, road, settle_s=settle_s,
                               sample_rate_hz=sample_rate_hz, warn=False, keep_series=True,
                               identified_range_m_per_s=identified_range_m_per_s,
                               sample_limits=sample_limits)
    slopes = equivalent_damping_slope(sim)
    # PSDs: road (spatial) and stroke velocity (temporal), Welch with stated segments
    dx = road.speed_m_per_s / sample_rate_hz
    nper = welch_segment_length(sim.road_m.size)
    n_sp, g_sp = signal.welch(sim.road_m, fs=1.0 / dx, nperseg=nper)
    sel = n_sp > 0
    seg = (sim.road_m.size - nper) // (nper // 2) + 1  # scipy's default: 50 % overlap
    road_psd = {"n_cycles_per_m": n_sp[sel], "synth_m3": g_sp[sel],
                "target_m3": road_psd_m3(n_sp[sel], road.iso_class), "segments": seg,
                "nperseg": nper, "resolution": 1.0 / (nper * dx)}
    f_v, p_v = signal.welch(sim.series["stroke_velocity_m_s"], fs=sample_rate_hz,
                            nperseg=nper, axis=-1)
    intervals = None
    if n_seeds is not None:
        from .uncertainty import road_intervals
        intervals = road_intervals(vehicle, hs, fr, road, n_seeds=n_seeds, settle_s=settle_s,
                                   sample_rate_hz=sample_rate_hz, sample_limits=sample_limits,
                                   identified_range_m_per_s=identified_range_m_per_s)
    return RoadStudy(sim, cases, [loads[c] for c in cases], slopes, target, reachable,
                     road_psd, {"f_hz": f_v, "psd": p_v, "segments": seg, "nperseg": nper,
                                "resolution_hz": sample_rate_hz / nper},
                     frictions.source, title, intervals, identified_range_m_per_s,
                     sample_limits)


#: Hann segments of every Welch PSD of the road studies (50 % overlap): 8 segments give
#: each PSD bin ≈ 15 degrees of freedom (Welch 1967, Hann windows overlapping by half: a
#: bin's 95 % range is about 0.55–2.1 × its estimate), at a resolution 4.5 × coarser
#: than the record's.
WELCH_SEGMENTS = 8


def welch_segment_length(n_samples: int, segments: int = WELCH_SEGMENTS) -> int:
    """Segment length giving ``segments`` Hann segments overlapping by half in a record
    of ``n_samples``: 2 N / (K + 1)."""
    if n_samples < 4 * (segments + 1):
        raise ParameterError(f"Welch PSD: {n_samples} samples are too few for {segments} "
                             "segments; lengthen the road")
    return int(2 * n_samples // (segments + 1))

