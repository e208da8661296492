"""Plan the bench tests the road needs: optimal design of experiments for the friction.

The friction sets are identified up to the bench campaign's peak velocity; a vehicle on a
road puts its strokes elsewhere (a passenger car on class C at 100 km/h: σ_v ≈ 0.5 m/s).
:func:`plan_tests` proposes the next bench tests — sines (frequency, amplitude, load) or
constant-velocity triangle strokes — within the rig's limits, chosen to shrink the
uncertainty of the rod friction *where the road puts the strokes*:

* the current uncertainty is the best law's sandwich covariance Σ₀ from
  ``identification.json`` (:mod:`ehsa_opt.estimation.rod_law`); its information is Σ₀⁺;
* a candidate test adds the Fisher information of its friction samples,
  I_c = n_eff,c mean_t g(v_t) g(v_t)ᵀ / σ², with g the gradient of F_rod(v) in the
  friction parameters at the best law, σ the residual level and n_eff,c the effective
  number of independent samples a record of its length carries, as the campaign's
  tests show it (:func:`effective_samples`; a 20 s record of a 0.1 Hz sine is not ten
  tests' worth: its residual is smooth over the slow cycle).  On a rigid bench the force samples carry the friction at the prescribed
  velocity; the load only sets the force and power the rig must deliver;
* the road's stroke velocity is Gaussian with the σ_v of the vehicle's design on its
  road (friction-aware fast path, :func:`ehsa_opt.vehicle.fast_path.friction_metrics`)
  and W = E_road[w(v) g gᵀ], w(v) ∝ F_rod(v) |v| by default (the friction's dissipated
  power: a velocity counts as much as the friction energy the road spends there, what
  power, damping and comfort depend on; ``weight="time"``: w = 1, the share of the time,
  which the many slow strokes dominate); the **A-optimal** criterion (road-weighted,
  also called I-optimal) is tr(W Σ), the **D-optimal** one −log det of the information
  on its identifiable subspace;
* tests are chosen greedily, one at a time, each the candidate that improves the
  criterion most given those already chosen.

Pyomo.DoE reports the same kind of thing for a model and a candidate set: the Fisher
information of the chosen experiments and the A-, D-, E-optimality values; here the
model is the friction regression and the report is the predicted band.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from ..estimation.rod_law import Z95, RodLawFit, rod_gradient
from ..physics.harvester import equivalent_damping_Ns_per_m, equivalent_mass_kg
from ..physics.params import HarvesterParams, ParameterError
from .rig import SLOWEST_TRIANGLE_M_PER_S, RigLimits, load_rig
from .test_loads import damper_loads, sine_peak_force_power, triangle_peak_force_N

__all__ = ["RigLimits", "load_rig", "Candidate", "candidate_tests", "TestPlan", "plan_tests",
           "road_velocity_sigma", "plan_from_files", "triangle_resolved_velocity",
           "residual_model", "effective_samples"]

_KINDS = ("sine", "triangle")
#: Fewest resolved samples a triangle candidate must keep (as a recorded test to be fitted).
_MIN_RESOLVED = 20


@dataclass(frozen=True)
class Candidate:
    """One candidate bench test."""

    kind: str
    amplitude_m: float
    load_ohm: float
    frequency_hz: float | None = None
    velocity_m_per_s: float | None = None   # triangle: the constant stroke velocity
    peak_velocity_m_per_s: float = 0.0
    peak_force_N: float = 0.0
    peak_power_W: float = 0.0
    peak_acceleration_m_per_s2: float = 0.0
    cycles: float = 2.0
    peak_screw_speed_rpm: float = 0.0
    peak_voltage_V: float = 0.0
    peak_current_A: float = 0.0

    @property
    def file(self) -> str:
        if self.kind == "sine":
            return (f"plan_f{self.frequency_hz:.3g}Hz_A{1e3 * self.amplitude_m:.3g}mm_"
                    f"Re{self.load_ohm:g}.csv")
        return (f"plan_tri_v{self.velocity_m_per_s:.3g}_A{1e3 * self.amplitude_m:.3g}mm_"
                f"Re{self.load_ohm:g}.csv")

    def label(self) -> str:
        if self.kind == "sine":
            return (f"sine {self.frequency_hz:.3g} Hz x {1e3 * self.amplitude_m:.3g} mm, "
                    f"R_e {self.load_ohm:g} ohm (peak {self.peak_velocity_m_per_s:.2f} m/s)")
        return (f"triangle +-{self.velocity_m_per_s:.3g} m/s over +-{1e3 * self.amplitude_m:.3g}"
                f" mm, R_e {self.load_ohm:g} ohm")

    def velocity_samples(self, rig: RigLimits) -> np.ndarray:
        """Stroke velocity (m/s) at the recorded samples that give friction samples: every
        sample of a sine; of a triangle stroke only those outside the reversal windows
        (:func:`triangle_resolved_velocity`)."""
        fs = rig.sample_rate_hz
        if self.kind == "sine":
            n = max(int(round(self.cycles * fs / self.frequency_hz)), 8)
            t = np.arange(n) / fs
            return self.peak_velocity_m_per_s * np.cos(2 * math.pi * self.frequency_hz * t)
        return triangle_resolved_velocity(self.velocity_m_per_s, self.amplitude_m, rig,
                                          self.cycles)

    def acceleration_m_per_s2(self, rig: RigLimits) -> float:
        """Peak stroke acceleration at the samples that give friction samples (m/s²): ω²A
        for a sine, ≈ 0 on a triangle's plateaus (its reversals are left out)."""
        if self.kind == "sine":
            return float((2 * math.pi * self.frequency_hz) ** 2 * self.amplitude_m)
        return 0.0


def triangle_resolved_velocity(velocity_m_per_s: float, amplitude_m: float, rig: RigLimits,
                               cycles: float | None = None) -> np.ndarray:
    """Stroke velocity (m/s) at the resolved samples of a constant-velocity triangle
    stroke over ±``amplitude_m`` recorded on ``rig``: the stroke (reversal ``reversal_s``,
    :class:`~ehsa_opt.datasets.protocols.Protocol` with corners of half that) is sampled,
    and the identification's motion estimate
    (:func:`~ehsa_opt.estimation.identify_options.estimate_motion`) leaves out the
    reversal windows, where the force is the corner's inertia and impacts.  Empty when
    nothing is resolved (a stroke too short for its speed)."""
    from ..datasets.bench_format import BenchTest
    from ..datasets.protocols import Protocol
    from ..estimation.identify_options import IdentifyOptions, estimate_motion
    proto = Protocol("triangle", 1.0, amplitude_m=float(amplitude_m),
                     velocity_m_per_s=float(velocity_m_per_s), corner_s=0.5 * rig.reversal_s)
    proto = dataclasses.replace(proto, duration_s=(cycles or rig.cycles) * proto.cycle_s)
    dt = 1.0 / rig.sample_rate_hz
    t = np.arange(int(round(proto.record_s / dt)) + 1) * dt
    x, v = proto.motion().evaluate(t)[:2]
    test = BenchTest("plan.csv", None, None, 1.0, "recorded", t, np.asarray(x, dtype=float),
                     np.zeros(t.size))
    resolved = estimate_motion(test, IdentifyOptions()).resolved
    if resolved.sum() < _MIN_RESOLVED:
        return np.zeros(0)
    return np.asarray(v, dtype=float)[resolved]


def candidate_tests(rig: RigLimits, harvester: HarvesterParams, law: RodLawFit,
                    kinds: Sequence[str] = _KINDS, n_freq: int = 24, n_amp: int = 6
                    ) -> list[Candidate]:
    """Sines (log-spaced frequencies × amplitudes up to the usable stroke) and triangle
    strokes (``n_freq`` log-spaced velocities over the usable stroke), at every load, that
    stay within the rig's stroke (less its margin), velocity, force and power and within
    the damper's screw speed, generator voltage and current where the rig file gives them.
    Force and power are the exact peaks of the test's own motion
    (:mod:`ehsa_opt.design.test_loads`); each test runs ``rig.cycles`` or as many more as
    ``rig.min_plateau_s`` of usable samples needs."""
    for k in kinds:
        if k not in _KINDS:
            raise ParameterError(f"plan-tests: unknown test kind '{k}' (valid: "
                                 f"{', '.join(_KINDS)})")
    meq = equivalent_mass_kg(harvester)
    out = []
    a_max = rig.usable_amplitude_m
    amps = np.linspace(0.1, 1.0, n_amp) * a_max
    for load in rig.loads_ohm:
        h = harvester.replace(load_ohm=float(load))
        if "sine" in kinds:
            for f in np.geomspace(rig.min_frequency_hz, rig.max_frequency_hz, n_freq):
                w = 2 * math.pi * f
                ceq = float(equivalent_damping_Ns_per_m(h, w))
                cycles = max(rig.cycles, math.ceil(rig.min_plateau_s * f))
                for a in amps:
                    F, P = sine_peak_force_power(meq, ceq, float(a), float(f), law.rod_N)
                    out.append(_with_loads(Candidate(
                        "sine", float(a), float(load), float(f), None, float(w * a), F, P,
                        float(w * w * a), float(cycles)), h))
        if "triangle" in kinds:
            ceq = float(equivalent_damping_Ns_per_m(h, 0.0))
            for v in np.geomspace(SLOWEST_TRIANGLE_M_PER_S, rig.peak_velocity_m_per_s,
                                 n_freq):
                plateau = 2.0 * (2.0 * a_max / v - rig.reversal_s)  # per cycle
                if plateau <= 0.0:
                    continue
                F = triangle_peak_force_N(meq, ceq, float(v), rig.reversal_s, law.rod_N)
                cycles = max(rig.cycles, math.ceil(rig.min_plateau_s / plateau))
                out.append(_with_loads(Candidate(
                    "triangle", float(a_max), float(load), None, float(v), float(v), F,
                    F * float(v), float(2.0 * v / rig.reversal_s), float(cycles)), h))
    return [c for c in out if _within(c, rig)]


def _with_loads(c: Candidate, h: HarvesterParams) -> Candidate:
    """The candidate with the damper's peak screw speed, voltage and current."""
    d = damper_loads(c.peak_velocity_m_per_s, h.lead_m_per_rad, h.voltage_constant_Vs_per_rad,
                     c.load_ohm, h.internal_resistance_ohm)
    return dataclasses.replace(c, peak_screw_speed_rpm=d["screw_speed_rpm"],
                               peak_voltage_V=d["voltage_V"], peak_current_A=d["current_A"])


def _within(c: Candidate, rig: RigLimits) -> bool:
    """Whether a candidate stays within every limit of the rig and of the damper."""
    tol = 1 + 1e-9
    damper = ((rig.max_screw_speed_rpm, c.peak_screw_speed_rpm),
              (rig.max_generator_voltage_V, c.peak_voltage_V),
              (rig.max_generator_current_A, c.peak_current_A))
    return (c.peak_velocity_m_per_s <= rig.peak_velocity_m_per_s * tol
            and c.amplitude_m <= rig.usable_amplitude_m * tol
            and c.peak_force_N <= rig.force_N and c.peak_power_W <= rig.actuator_power_W
            and all(lim is None or val <= lim * tol for lim, val in damper))


def road_velocity_sigma(problem: Any, friction: Any) -> float:
    """σ_v (m/s) of a quarter-car problem's design on its road with ``friction`` (fast
    path)."""
    from ..vehicle.fast_path import friction_metrics
    m = friction_metrics(problem.vehicle, problem.road, None, friction, base=problem.harvester)
    return float(np.asarray(m["stroke_velocity_rms_m_s"]).ravel()[0])


@dataclass
class TestPlan:
    """Result of :func:`plan_tests` (``success`` / ``message`` as scipy's results)."""

    success: bool
    message: str
    proposed: list[Candidate]
    criterion: str
    sigma_v_m_per_s: float
    velocities_m_per_s: list[float]
    band_before_N: list[float]
    band_after_N: list[float]
    road_band_before_N: float
    road_band_after_N: float
    steps: list[dict] = field(default_factory=list)
    n_candidates: int = 0
    rig: RigLimits = field(default_factory=RigLimits)
    identified_range_m_per_s: float = math.nan

    def lines(self) -> list[str]:
        """The printed report."""
        out = [f"{self.message}",
               f"road: stroke velocity sigma {self.sigma_v_m_per_s:.3f} m/s (Gaussian); "
               f"identified up to {self.identified_range_m_per_s:.3g} m/s; "
               f"{self.n_candidates} candidate tests within the rig's limits; "
               f"{self.criterion}-optimal greedy choice:"]
        for k, (c, st) in enumerate(zip(self.proposed, self.steps), 1):
            res = st.get("predicted_residual_rms_N")
            neff = st.get("effective_samples")
            out.append(f"  {k}. {c.label()}, {c.cycles:g} cycles: peak force "
                       f"{c.peak_force_N:.0f} N, power {c.peak_power_W:.0f} W; damper "
                       f"{c.peak_screw_speed_rpm:.0f} rpm, {c.peak_voltage_V:.1f} V, "
                       f"{c.peak_current_A:.2f} A"
                       + (f", expected residual {res:.0f} N rms" if res is not None else "")
                       + (f" on {neff:.0f} effective samples" if neff is not None else "")
                       + f" -> road-weighted band +-{st['road_band_N']:.1f} N")
        unchecked = [n for n, v in (("screw speed", self.rig.max_screw_speed_rpm),
                                    ("generator voltage", self.rig.max_generator_voltage_V),
                                    ("generator current", self.rig.max_generator_current_A))
                     if v is None]
        out.append(f"rig: stroke +-{1e3 * self.rig.usable_amplitude_m:.3g} mm usable "
                   f"({1e3 * self.rig.stroke_margin_m:g} mm margin at each end), at least "
                   f"{self.rig.min_plateau_s:g} s of usable samples per test"
                   + (f"; NOT checked (no limit in [rig]): {', '.join(unchecked)}"
                      if unchecked else "; damper limits checked"))
        out.append("predicted 95 % band of the rod friction (+- N), before -> after:")
        for v, b, a in zip(self.velocities_m_per_s, self.band_before_N, self.band_after_N):
            out.append(f"  at {v:4.2f} m/s: {b:7.1f} -> {a:7.1f}")
        out.append(f"  road-weighted (rms over the road's velocities): "
                   f"{self.road_band_before_N:.1f} -> {self.road_band_after_N:.1f}")
        return out

    def bench_toml(self, harvester: Mapping[str, Any] | None = None) -> str:
        """A ``bench.toml`` skeleton of the proposed tests (record them into the named CSVs,
        header ``time_s,displacement_m,force_N,voltage_V``)."""
        lines = ["# Bench tests proposed by `ehsa-opt plan-tests`: record each into the named",
                 "# CSV (time_s,displacement_m,force_N,voltage_V), then identify this",
                 "# directory together with the earlier campaign.", ""]
        if harvester:
            lines.append("[harvester]")
            lines += [f"{k} = {float(v)!r}" for k, v in harvester.items()]
            lines.append("")
        for c in self.proposed:
            lines.append("[[test]]")
            lines.append(f'file = "{c.file}"')
            if c.kind == "sine":
                lines += [f"frequency_hz = {c.frequency_hz:.4g}",
                          f"amplitude_m = {c.amplitude_m:.4g}",
                          f"# record {c.cycles:g} cycles"]
            else:
                lines += ['excitation = "recorded"',
                          f"# constant-velocity triangle strokes: +-{c.velocity_m_per_s:.4g} "
                          f"m/s over +-{c.amplitude_m:.4g} m, {c.cycles:g} cycles, "
                          f"reversal {self.rig.reversal_s:g} s"]
            lines += [f"load_ohm = {c.load_ohm:g}", ""]
        return "\n".join(lines)

    def write(self, out_dir: str | Path, harvester: Mapping[str, Any] | None = None
              ) -> list[str]:
        """Write ``bench.toml`` (the skeleton) and ``plan.json`` atomically into ``out_dir``
        (nothing when no test was proposed); returns the lines that say so."""
        from ..utils.io import atomic_write_json, atomic_write_text
        if not self.success:
            return []
        out = Path(out_dir)
        atomic_write_text(out / "bench.toml", self.bench_toml(harvester))
        atomic_write_json(out / "plan.json", self.to_dict())
        return [f"wrote {out / 'bench.toml'} (skeleton for the rig operator) and "
                f"{out / 'plan.json'}"]

    def summary(self) -> str:
        """The printed report (:meth:`lines`) as one text."""
        return "\n".join(self.lines())

    def to_dict(self) -> dict:
        """plan.json as standard-JSON types (:meth:`from_dict` reloads it)."""
        return {"success": self.success, "message": self.message, "criterion": self.criterion,
                "sigma_v_m_per_s": self.sigma_v_m_per_s,
                "identified_range_m_per_s": self.identified_range_m_per_s,
                "proposed": [dict(asdict(c), file=c.file) for c in self.proposed],
                "steps": self.steps, "n_candidates": self.n_candidates,
                "velocities_m_per_s": self.velocities_m_per_s,
                "band_before_N": self.band_before_N, "band_after_N": self.band_after_N,
                "road_band_before_N": self.road_band_before_N,
                "road_band_after_N": self.road_band_after_N, "rig": asdict(self.rig)}

    def to_json(self) -> str:
        """:meth:`to_dict` as JSON text (reloaded by :meth:`from_json`)."""
        from ..utils.io import json_safe
        return json.dumps(json_safe(self.to_dict()), indent=1, allow_nan=False)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "TestPlan":
        """Reload a plan from :meth:`to_dict` (a plan.json)."""
        fields_ = {f.name for f in fields(Candidate)}
        return cls(bool(d["success"]), str(d["message"]),
                   [Candidate(**{k: v for k, v in c.items() if k in fields_})
                    for c in d["proposed"]], str(d["criterion"]), float(d["sigma_v_m_per_s"]),
                   list(d["velocities_m_per_s"]), list(d["band_before_N"]),
                   list(d["band_after_N"]), float(d["road_band_before_N"]),
                   float(d["road_band_after_N"]), list(d.get("steps", [])),
                   int(d.get("n_candidates", 0)),
                   RigLimits(**{**d["rig"], "loads_ohm": tuple(d["rig"]["loads_ohm"])}),
                   float(d.get("identified_range_m_per_s") or math.nan))

    @classmethod
    def from_json(cls, text: str) -> "TestPlan":
        """Reload a plan written by :meth:`to_json`."""
        return cls.from_dict(json.loads(text))


def residual_model(law: RodLawFit) -> tuple[float, float]:
    """How the campaign's model error grows with a test's stroke acceleration: the
    friction samples' residual variance of every test, σ_g² = σ₀² + β a_g² (a_g its peak
    acceleration), fitted by non-negative least squares over the tests.  A hidden
    backlash or compliance adds force in proportion to how hard the stroke is driven;
    the noise floor σ₀ is what a test at no acceleration keeps.  Returns (σ₀², β) in N²
    and N² s⁴/m²; (residual_rms², 0) when the tests' accelerations are not known."""
    from scipy.optimize import nnls
    r = np.asarray(law.test_residual_rms_N, dtype=float)
    a = np.asarray(law.test_peak_acceleration_m_per_s2, dtype=float)
    ok = np.isfinite(r) & np.isfinite(a)
    flat = (max(law.residual_rms_N, 1e-9) ** 2, 0.0)
    if r.size != a.size or ok.sum() < 3 or np.ptp(a[ok]) <= 0:
        return flat
    A = np.column_stack([np.ones(ok.sum()), a[ok] ** 2])
    # relative errors (each test's variance known to a factor): rows scaled by 1/σ_g²
    w = 1.0 / np.maximum(r[ok] ** 2, 1e-12)
    coef, _ = nnls(A * w[:, None], r[ok] ** 2 * w)
    s0 = float(coef[0]) if coef[0] > 0 else float(np.min(r[ok] ** 2))
    return max(s0, 1e-12), float(coef[1])


def effective_samples(law: RodLawFit, n_samples: Any) -> np.ndarray:
    """Effective number of independent friction samples in a record of ``n_samples``
    samples, as the campaign's tests show it.

    Every campaign test has n_g samples and n_eff,g = n_g / τ_g (``test_n_effective``: its
    residuals' autocorrelation), the median per length interpolated in log–log; shorter
    than every test: the shortest's inflation; longer than every test: the longest's
    n_eff — nothing says an error decorrelates over a longer record than any measured, and
    the slow tests' residual is the smoothest (embedded campaign: τ 1 at 2–3.5 Hz, 15 at
    0.5 Hz).  Laws of earlier versions (no per-test counts): the mean inflation n/n_eff,
    at most the average test length.
    """
    n = np.asarray(n_samples, dtype=float)
    ns = np.asarray(law.test_n_samples, dtype=float)
    ne = np.asarray(law.test_n_effective, dtype=float)
    ok = (np.isfinite(ns) & np.isfinite(ne) & (ns > 0) & (ne > 0)
          if ns.size == ne.size else np.zeros(0, dtype=bool))
    if not ok.any():
        tau = law.n_samples / max(law.n_effective, 1.0)
        return np.minimum(n, law.n_samples / max(law.n_tests, 1)) / tau
    ns, ne = ns[ok], np.minimum(ne[ok], ns[ok])
    lengths = np.unique(ns)
    neff = np.array([np.median(ne[ns == L]) for L in lengths])
    out = np.exp(np.interp(np.log(np.maximum(n, 1.0)), np.log(lengths), np.log(neff)))
    out = np.where(n < lengths[0], n * neff[0] / lengths[0], out)
    return np.minimum(out, n)


def _candidate_information(cands: list[Candidate], rig: RigLimits, law: RodLawFit,
                           d: np.ndarray, kappa: float
                           ) -> tuple[list[Candidate], list[np.ndarray], list[float],
                                      list[float]]:
    """The candidates that keep resolved samples, the Fisher information of each (in the
    coordinates scaled by ``d``), its expected residual rms (N) — the campaign's error
    at the candidate's stroke acceleration (:func:`residual_model`) — and its effective
    number of samples (:func:`effective_samples`); the information is deflated by the
    cluster factor ``kappa``."""
    s0, beta = residual_model(law)
    p, names, lead = law.parameters, law.free, law.lead_m_per_rad
    infos, kept, sig, neffs = [], [], [], []
    tri_v: dict[float, np.ndarray] = {}
    for c in cands:
        if c.kind == "triangle":
            if c.velocity_m_per_s not in tri_v:  # the same stroke at every load
                tri_v[c.velocity_m_per_s] = c.velocity_samples(rig)
            v = tri_v[c.velocity_m_per_s]
        else:
            v = c.velocity_samples(rig)
        if v.size < _MIN_RESOLVED:
            continue  # all reversal: nothing a fit would use
        s2 = s0 + beta * c.acceleration_m_per_s2(rig) ** 2
        n_eff = float(effective_samples(law, v.size))
        # the information is n_eff × the mean of g gᵀ over the samples: 400 evenly spaced
        # ones give the mean of these smooth periodic records to well below a per cent
        sub = v[np.unique(np.linspace(0, v.size - 1, min(v.size, 400)).astype(int))]
        G = rod_gradient(sub, p, names, lead) * d
        infos.append(n_eff * (G.T @ G) / sub.size / (s2 / kappa))
        kept.append(c)
        sig.append(math.sqrt(s2))
        neffs.append(n_eff)
    return kept, infos, sig, neffs


def _pinv(A: np.ndarray, rcond: float = 1e-9) -> np.ndarray:
    ev, V = np.linalg.eigh(0.5 * (A + A.T))
    keep = ev > rcond * max(float(ev.max()), 1e-300)
    return (V[:, keep] / ev[keep]) @ V[:, keep].T


def plan_tests(law: RodLawFit, rig: RigLimits, harvester: HarvesterParams,
               sigma_v_m_per_s: float, *, n_tests: int = 3, criterion: str = "A",
               kinds: Sequence[str] = _KINDS,
               velocities_m_per_s: Sequence[float] = (0.5, 1.0, 1.5),
               weight: str = "energy") -> TestPlan:
    """Greedy optimal design of ``n_tests`` bench tests (see the module docstring).

    Parameters
    ----------
    law : RodLawFit
        The best law and its covariance (``identification.json``).
    rig : RigLimits
    harvester : HarvesterParams
        The bench's harvester (force and power of a candidate).
    sigma_v_m_per_s : float
        The road's stroke-velocity σ (:func:`road_velocity_sigma`).
    criterion : {"A", "D"}
        Road-weighted A-optimal (default) or D-optimal.
    weight : {"energy", "time"}
        How the road weights the velocities in the A-optimal criterion: by the friction's
        dissipated power F_rod(v) |v| times the road's density (default: the share of the
        friction's energy a velocity carries, what the vehicle results depend on), or by
        the density alone (the share of the time).
    """
    if criterion not in ("A", "D"):
        raise ParameterError(f"plan-tests: criterion must be 'A' or 'D', got {criterion!r}")
    if weight not in ("energy", "time"):
        raise ParameterError(f"plan-tests: weight must be 'energy' or 'time', got {weight!r}")
    if not (isinstance(n_tests, int) and n_tests >= 1):
        raise ParameterError(f"plan-tests: the number of tests must be >= 1, got {n_tests!r}")
    cands = candidate_tests(rig, harvester, law, kinds)
    if not cands:
        return TestPlan(False, "no candidate test fits the rig's and the damper's limits: "
                        "raise peak_velocity_m_per_s, force_N, actuator_power_W or the "
                        "damper's max_* limits, or lower stroke_margin_m in [rig]", [],
                        criterion, sigma_v_m_per_s, list(velocities_m_per_s), [], [],
                        math.nan, math.nan, [], 0, rig, law.velocity_range_m_per_s[1])
    names, p, lead = law.free, law.parameters, law.lead_m_per_rad
    # road weight: |v| half-normal, Gauss-Legendre on [0, 5 sigma]
    x, wq = np.polynomial.legendre.leggauss(64)
    vr = 2.5 * sigma_v_m_per_s * (x + 1.0)
    wr = wq * 2.5 * sigma_v_m_per_s * 2.0 * np.exp(-0.5 * (vr / sigma_v_m_per_s) ** 2) / (
        sigma_v_m_per_s * math.sqrt(2 * math.pi))
    if weight == "energy":
        pw = np.maximum(law.rod_N(vr), 0.0) * vr
        wr = wr * pw / max(float(np.sum(wr * pw)), 1e-300)
    Graw = rod_gradient(vr, p, names, lead)
    Wraw = (Graw * wr[:, None]).T @ Graw
    # the band the identification reports is the larger of Newey-West and cluster-robust;
    # where the cluster-robust one is larger (an error shared by the cycles of a test), a
    # new test is worth less than its samples say by the same factor kappa
    cov0, kappa = law.covariance, 1.0
    if law.covariance_cluster is not None:
        a_nw = float(np.trace(Wraw @ law.covariance))
        a_cl = float(np.trace(Wraw @ law.covariance_cluster))
        if a_cl > a_nw > 0:
            cov0, kappa = law.covariance_cluster, a_nw / a_cl
    # scaled coordinates: the covariance's own standard deviations
    d = np.sqrt(np.maximum(np.diag(cov0), 1e-300))
    J0 = _pinv(cov0 / np.outer(d, d))
    Gr = Graw * d
    W = (Gr * wr[:, None]).T @ Gr
    cands, infos, sig, neffs = _candidate_information(cands, rig, law, d, kappa)
    if not cands:
        return TestPlan(False, "no candidate test keeps resolved samples within the rig's "
                        "limits: raise stroke_m or peak_velocity_m_per_s in [rig]", [],
                        criterion, sigma_v_m_per_s, list(velocities_m_per_s), [], [],
                        math.nan, math.nan, [], 0, rig, law.velocity_range_m_per_s[1])

    def score(J: np.ndarray) -> float:
        if criterion == "A":
            return float(np.trace(W @ _pinv(J)))
        ev = np.linalg.eigvalsh(0.5 * (J + J.T))
        ev = ev[ev > 1e-9 * ev.max()]
        return -float(np.sum(np.log(ev)))

    def road_band(J: np.ndarray) -> float:
        return float(Z95 * math.sqrt(max(np.trace(W @ _pinv(J)), 0.0)))

    J = J0.copy()
    chosen, steps = [], []
    for _ in range(min(n_tests, len(cands))):
        # distinct tests (a repeat is a new realisation of the same test; give the
        # operator different ones)
        k = int(np.argmin([score(J + I) if c not in chosen else np.inf
                           for c, I in zip(cands, infos)]))
        J = J + infos[k]
        chosen.append(cands[k])
        steps.append({"file": cands[k].file, "criterion": score(J), "road_band_N": road_band(J),
                      "predicted_residual_rms_N": sig[k], "effective_samples": neffs[k]})
    Gv = rod_gradient(np.asarray(velocities_m_per_s, dtype=float), p, names, lead) * d

    def band(Jm: np.ndarray) -> list[float]:
        C = _pinv(Jm)
        return [float(Z95 * math.sqrt(max(g @ C @ g, 0.0))) for g in Gv]
    msg = (f"{len(chosen)} test(s) proposed; predicted road-weighted band "
           f"+-{road_band(J0):.1f} -> +-{road_band(J):.1f} N"
           + (f" (cluster-robust covariance, new information x{kappa:.2f})"
              if kappa < 1.0 else ""))
    return TestPlan(True, msg, chosen, criterion, float(sigma_v_m_per_s),
                    [float(v) for v in velocities_m_per_s], band(J0), band(J), road_band(J0),
                    road_band(J), steps, len(cands), rig, float(law.velocity_range_m_per_s[1]))


def plan_from_files(ident_path: str | Path, vehicle_path: str | Path, rig_path: str | Path,
                    *, n_tests: int = 3, criterion: str = "A",
                    kinds: Sequence[str] = _KINDS, weight: str = "energy"
                    ) -> tuple[TestPlan, dict]:
    """:func:`plan_tests` from an ``identification.json``, a quarter-car problem file and a
    rig file.  Returns the plan and the bench's ``[harvester]`` table (for the skeleton)."""
    from ..datasets.friction_source import FrictionSets
    from ..datasets.identification_file import bench_harvester, read_identification
    from ..datasets.problem_file import load_problem
    ident_path = Path(ident_path)
    rig = load_rig(rig_path)
    prob = load_problem(vehicle_path)
    doc = read_identification(ident_path)  # every table validated (law, sets, ranges)
    if not isinstance(doc.get("friction_sets"), Mapping):
        raise ParameterError(f"{ident_path}: no 'friction_sets' table (not an identification "
                             f"result, or its fits failed); re-run `ehsa-opt identify`")
    sets = FrictionSets.from_dict(doc["friction_sets"], f"{ident_path} friction_sets")
    law_doc = ((doc.get("friction_envelope") or {}).get("extrapolation_band") or {}).get("law")
    if not isinstance(law_doc, Mapping):
        raise ParameterError(f"{ident_path}: no friction_envelope.extrapolation_band.law "
                             f"(written by an older ehsa_opt); re-run `ehsa-opt identify`")
    law = RodLawFit.from_dict(law_doc, f"{ident_path} friction_envelope.extrapolation_band.law")
    harvester, harv_tab = bench_harvester(doc, ident_path)
    sigma = road_velocity_sigma(prob, sets.best)
    return plan_tests(law, rig, harvester, sigma, n_tests=n_tests, criterion=criterion,
                      kinds=kinds, weight=weight), harv_tab
