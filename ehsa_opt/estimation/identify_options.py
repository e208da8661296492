"""Settings of the identification (:class:`IdentifyOptions`), its parameter bounds and
start ranges, and the prescribed motion of a test (:func:`test_motion`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..datasets.bench_format import BenchTest
from ..physics.motion import SampledMotion
from ..physics.base_parameters import PARAMETERS, Parameter, override
from ..physics.params import FRICTION_NAMES
from .collocation import node_indices

__all__ = ["IdentifyOptions", "IDENTIFY_PARAMETERS", "PARAMETER_BOUNDS", "START_RANGES",
           "test_motion",
           "MotionEstimate", "estimate_motion", "RECORDED_CUTOFF_FACTORS", "CORNER_WINDOW_CYCLES",
           "MIN_RESOLVED_SAMPLES", "unresolved_tests"]

#: Cut-offs tried for recorded (non-sine) tests, as multiples of the sine cut-off; the
#: largest whose acceleration noise stays at half the force noise is kept.
RECORDED_CUTOFF_FACTORS: tuple[float, ...] = (1.0, 1.5, 2.0, 3.0)
#: Margin added on each side of an unresolved corner, in cycles of the sine cut-off
#: (0.5 / 30 Hz: 17 ms; the flagged extent itself shrinks as 1 / f_c).
CORNER_WINDOW_CYCLES: float = 0.5
#: Threshold on the two-cut-off acceleration difference, in its noise standard deviations.
CORNER_THRESHOLD_SIGMA: float = 6.0
#: Samples left out at each end of a recorded test, in cycles of the sine cut-off
#: (1 / 30 Hz: 33 ms).
END_WINDOW_CYCLES: float = 1.0
#: Recorded samples whose estimated speed is below this many of its noise standard
#: deviations are "at rest" and stay out of objectives.
DWELL_THRESHOLD_SIGMA: float = 3.0

#: The identification's parameters: the declaration
#: (:data:`~ehsa_opt.physics.base_parameters.PARAMETERS`) with the friction bounded by the
#: distributor ranges' upper ends (lower ends 0 for levels and viscous terms, so "no
#: friction" stays admissible; the distributor ranges for breakaway velocities).
IDENTIFY_PARAMETERS: dict[str, Parameter] = override(
    "identification",
    "a presliding stiffness below 1e4 N/m would spread a 50 N contact's transition over "
    "5 mm (a stroke, not presliding) and one above 1e9 N/m over less than 0.1 um (nothing a "
    "bench resolves); the bristle damping stays below 1e5 N s/m (a 1 kHz corner on a 1e9 N/m "
    "bristle)",
    {"presliding_stiffness_N_per_m": (1e4, 1e9),
     "presliding_damping_Ns_per_m": (0.0, 1e5)},
    base=override(
        "identification",
        "without bounds the unmodelled backlash of the embedded data drives Stribeck bumps to "
        "1000 N at 0.2 m/s, far outside any ball screw: the friction stays inside the "
        "distributor ranges' upper ends",
        {n: ((PARAMETERS[n].start[0] if PARAMETERS[n].lower_open else PARAMETERS[n].lower),
             PARAMETERS[n].start[1]) for n in FRICTION_NAMES}))

#: Admissible bounds (lower, upper, scale) of the parameters during identification
#: (from :data:`IDENTIFY_PARAMETERS`).
PARAMETER_BOUNDS: dict[str, tuple[float, float, float]] = {
    n: (q.lower, q.upper, q.scale) for n, q in IDENTIFY_PARAMETERS.items()}

#: Ranges the multistart draws from: the declaration's start ranges.
START_RANGES: dict[str, tuple[float, float]] = {n: q.start for n, q in PARAMETERS.items()}


# ====================================================================== options
@dataclass(frozen=True)
class IdentifyOptions:
    """Settings of the collocation NLP and IPOPT.

    Attributes
    ----------
    degree : int
        Radau collocation degree d (1–9).
    max_intervals : int
        Collocation intervals per test; longer records are decimated to this
        many intervals (nodes on measured samples).
    max_samples : int
        Samples per test entering the objective (decimated uniformly if the
        record is longer); states between nodes come from the collocation
        polynomials, so short events such as velocity reversals are not missed.
    tol : float
        IPOPT ``tol`` (scaled NLP error, dimensionless).  1e-6: tighter than the
        data justify costs iterations only; against 1e-8 the best objectives of the
        seed-7 bench change by < 0.1 % (a χ² change of one noise sample is ~2/n,
        0.3 % for n = 600 samples) and the rod friction by < 5e-4 relative.
    max_iter : int
        IPOPT ``max_iter``.
    sum_weight : float
        w in ``t + w·mean(J)`` (≥ 0; see the module docstring).
    objective_scale : float
        Constant factor on the objective (conditioning only).
    smoothing : float or None
        ``lam`` of the displacement smoothing spline (None: GCV).
    spline_points : int
        With GCV, the smoothing spline is fitted to at most
        max(spline_points, n/10) of a test's n displacement samples (uniformly
        decimated; GCV costs ~0.3 ms per point).
    smoothing_cutoff_hz : float or None
        If given (and ``smoothing`` is None), the spline penalty is set from an
        equivalent low-pass cut-off f_c: the smoothing spline's response is
        1/(1 + λ Δt ω⁴), so λ = 1/(Δt (2π f_c)⁴), and all samples are used.
        Default 30 Hz (the sine tests are ≤ 3.5 Hz; 2 µm displacement noise
        stays below the 2 N force noise); None selects GCV, which over-smooths
        1 kHz records (force rms error 5.8 N instead of 2.2 N at 3.5 Hz; EMPS:
        M +7 %); see :meth:`for_rig`.
    trim_fraction : float
        Fraction of each record left out of the objective at each end, where
        the spline's derivatives are least accurate (0–0.2).
    identifiable_rtol : float
        Fisher-information eigenvalues below this fraction of the largest mark
        a direction the data do not determine.
    path : {"auto", "rigid", "collocation"}
        ``auto``: the rigid path when no state depends on a varied parameter
        (states integrated once per test, parameters-only NLP), collocation
        otherwise; ``rigid`` refuses models with parameter-driven states.
    """

    degree: int = 3
    max_intervals: int = 100
    max_samples: int = 600
    tol: float = 1e-6
    max_iter: int = 500
    sum_weight: float = 0.1
    objective_scale: float = 100.0
    smoothing: float | None = None
    spline_points: int = 600
    smoothing_cutoff_hz: float | None = 30.0
    trim_fraction: float = 0.02
    identifiable_rtol: float = 1e-6
    path: str = "auto"

    def __post_init__(self) -> None:
        if not (isinstance(self.degree, int) and 1 <= self.degree <= 9):
            raise ValueError(f"IdentifyOptions: degree must be an integer 1..9, got "
                             f"{self.degree!r}")
        if not (isinstance(self.max_intervals, int) and self.max_intervals >= 4):
            raise ValueError("IdentifyOptions: max_intervals must be an integer >= 4, got "
                             f"{self.max_intervals!r}")
        if not (isinstance(self.max_samples, int) and self.max_samples >= 5):
            raise ValueError("IdentifyOptions: max_samples must be an integer >= 5, got "
                             f"{self.max_samples!r}")
        if not (isinstance(self.spline_points, int) and self.spline_points >= 10):
            raise ValueError("IdentifyOptions: spline_points must be an integer >= 10, got "
                             f"{self.spline_points!r}")
        if not (isinstance(self.max_iter, int) and self.max_iter >= 1):
            raise ValueError(f"IdentifyOptions: max_iter must be an integer >= 1, got "
                             f"{self.max_iter!r}")
        for name in ("tol", "objective_scale", "identifiable_rtol"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"IdentifyOptions: {name} must be > 0, got {v!r}")
        if not (isinstance(self.sum_weight, (int, float)) and self.sum_weight >= 0):
            raise ValueError(f"IdentifyOptions: sum_weight must be >= 0, got {self.sum_weight!r}")
        if not (0.0 <= self.trim_fraction < 0.2):
            raise ValueError("IdentifyOptions: trim_fraction must be in [0, 0.2), got "
                             f"{self.trim_fraction!r}")
        if self.smoothing is not None and not self.smoothing >= 0:
            raise ValueError("IdentifyOptions: smoothing must be None or >= 0")
        if self.path not in ("auto", "rigid", "collocation"):
            raise ValueError(f"IdentifyOptions: path must be 'auto', 'rigid' or 'collocation', "
                             f"got {self.path!r}")
        if self.smoothing_cutoff_hz is not None and not self.smoothing_cutoff_hz > 0:
            raise ValueError("IdentifyOptions: smoothing_cutoff_hz must be None or > 0 (Hz)")

    @classmethod
    def for_rig(cls, has_generator: bool, **changes: Any) -> "IdentifyOptions":
        """Defaults per rig: a 30 Hz smoothing cut-off for the sine bench tests; for
        rigs without generator (recorded motion, e.g. EMPS at 1 kHz) 60 Hz (which
        reproduces the published EMPS inertia) and up to 5000 objective samples."""
        base: dict[str, Any] = {} if has_generator else {"smoothing_cutoff_hz": 60.0,
                                                         "max_samples": 5000}
        base.update(changes)
        return cls(**base)





def _noise(y: np.ndarray) -> float:
    """White-noise level of a sampled signal from its second differences (robust)."""
    d2 = np.diff(np.asarray(y, float), 2)
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / math.sqrt(6.0))


@dataclass(frozen=True)
class MotionEstimate:
    """The prescribed motion of a test and where its derivatives are resolved.

    Attributes
    ----------
    motion : SampledMotion
    cutoff_hz : float or None
        Equivalent low-pass cut-off of the smoothing spline (None: GCV / given λ).
    resolved : ndarray of bool (n_samples,)
        False in windows around corners (acceleration steps: stroke reversals, starts,
        stops) that the spline cannot follow; those samples stay out of objectives.
    """

    motion: SampledMotion
    cutoff_hz: float | None
    resolved: np.ndarray


def _acc(t: np.ndarray, x: np.ndarray, fc: float) -> np.ndarray:
    return SampledMotion.with_cutoff(t, x, fc).evaluate(t)[2]


def estimate_motion(test: BenchTest, options: IdentifyOptions | None = None,
                    mass_kg: float | None = None) -> MotionEstimate:
    """Smoothing spline of the measured displacement, and its resolved samples.

    Sine tests: the spline at ``options.smoothing_cutoff_hz`` (every sample resolved).
    Recorded tests (constant-velocity strokes, trapezoids, multisines, road records):

    * cut-off: the largest of :data:`RECORDED_CUTOFF_FACTORS` × the sine cut-off whose
      acceleration noise (the spline applied to white noise of the displacement's
      noise level, seeded) times ``mass_kg`` (the rod-equivalent inertia) is at most
      half the force noise — sharper corners where the noise allows it;
    * corners: the spline's acceleration at f_c and at 2 f_c differ where the motion
      has content the spline cannot follow (an acceleration step); samples where the
      difference exceeds :data:`CORNER_THRESHOLD_SIGMA` noise standard deviations
      (and 1 % of the rms acceleration) are unresolved; around each such run (found at
      the sine cut-off f_0, its half-length h_0) the window c ± (h_0 f_0 / f_c +
      :data:`CORNER_WINDOW_CYCLES` / f_0) is left out;
    * ends: :data:`END_WINDOW_CYCLES` / f_0 at each end of the record (one-sided
      derivatives);
    * dwells: samples whose speed is below :data:`DWELL_THRESHOLD_SIGMA` of its noise
      (a rod at rest: the force there is whatever the stuck friction holds, which no
      function of the velocity gives).

    Accuracy outside the windows (tested: 1 kHz, 2 µm displacement noise, 2 N force
    noise, inertia 11.9 and 47.5 kg, so f_c = 60 and 30 Hz; triangles at 0.06–0.3 m/s
    with 1–10 ms corner blends, trapezoids, multisines, road-like records): velocity
    within 1 % of the peak speed, acceleration within 0.25 m/s² (rms < 0.06 m/s²).
    Nothing assumes the record is periodic.
    """
    opt = options or IdentifyOptions()
    key = _motion_key(test, opt, mass_kg)
    hit = _MOTIONS.get(key)
    if hit is None:
        hit = _MOTIONS[key] = _estimate_motion(test, opt, mass_kg)
        while len(_MOTIONS) > MOTION_CACHE_SIZE:
            _MOTIONS.pop(next(iter(_MOTIONS)))
    # the spline is immutable; the mask is the caller's to change
    return MotionEstimate(hit.motion, hit.cutoff_hz, hit.resolved.copy())


#: Motion estimates kept in this process (the identification, its friction samples, the
#: report and the discrepancy workflow ask for the same test's motion again; a smoothing
#: spline of a long record costs tens of ms).
MOTION_CACHE_SIZE = 48
_MOTIONS: dict[tuple, MotionEstimate] = {}


def _motion_key(test: BenchTest, opt: IdentifyOptions, mass_kg: float | None) -> tuple:
    """What :func:`estimate_motion` depends on: the samples (digest), the excitation,
    the smoothing settings and, for a recorded motion, the mass (a sine test's spline
    does not depend on it: the identification, which passes the model's mass, and the
    friction samples, which do not, share it)."""
    import hashlib
    h = hashlib.blake2b(digest_size=16)
    arrays = [test.time_s, test.displacement_m]
    if test.excitation != "sine":
        arrays.append(test.force_N)
    for a in arrays:
        a = np.ascontiguousarray(a, dtype=float)
        h.update(str(a.shape).encode())
        h.update(a.tobytes())
    return (h.hexdigest(), test.excitation, opt.smoothing, opt.smoothing_cutoff_hz,
            opt.spline_points,
            None if mass_kg is None or test.excitation == "sine" else float(mass_kg))


def _estimate_motion(test: BenchTest, opt: IdentifyOptions,
                     mass_kg: float | None) -> MotionEstimate:
    n = test.n_samples
    t, x = test.time_s, test.displacement_m
    if opt.smoothing is None and opt.smoothing_cutoff_hz is not None:
        fc = float(opt.smoothing_cutoff_hz)
        if test.excitation != "sine":
            return _recorded(test, fc, mass_kg)
        return MotionEstimate(SampledMotion.with_cutoff(t, x, fc), fc, np.ones(n, bool))
    m = n if opt.smoothing is not None else min(n, max(opt.spline_points, n // 10))
    idx = node_indices(n, m - 1)
    return MotionEstimate(SampledMotion(t[idx], x[idx], opt.smoothing), None, np.ones(n, bool))


def _recorded(test: BenchTest, fc0: float, mass_kg: float | None) -> MotionEstimate:
    t, x = test.time_s, test.displacement_m
    n = t.size
    dt = float(np.median(np.diff(t)))
    sx = _noise(x)
    e = np.random.default_rng(0).normal(0.0, sx, n) if sx > 0 else np.zeros(n)
    fc = fc0
    if mass_kg and sx > 0:
        sF = _noise(test.force_N)
        for k in RECORDED_CUTOFF_FACTORS:
            f = fc0 * k
            if 2 * f > 0.4 / dt:
                break
            if mass_kg * float(np.std(_acc(t, e, f))) <= 0.5 * sF:
                fc = f
    # corners found at the base cut-off (where the two-cut-off test has the power to
    # see them), their windows scaled to the cut-off in use
    a1 = _acc(t, x, fc0)
    da = _acc(t, x, 2 * fc0) - a1
    s_noise = float(np.std(_acc(t, e, 2 * fc0) - _acc(t, e, fc0))) if sx > 0 else 0.0
    thr = max(CORNER_THRESHOLD_SIGMA * s_noise, 0.01 * float(np.sqrt(np.mean(a1 ** 2))))
    flagged = np.flatnonzero(np.abs(da) > thr)
    resolved = np.ones(n, bool)
    if flagged.size:
        runs = np.split(flagged, np.flatnonzero(np.diff(flagged) > 1) + 1)
        for run in runs:
            c = 0.5 * (t[run[0]] + t[run[-1]])
            h = 0.5 * (t[run[-1]] - t[run[0]]) * fc0 / fc + CORNER_WINDOW_CYCLES / fc0
            resolved[(t >= c - h) & (t <= c + h)] = False
    # the record's ends: one-sided, the spline's derivatives there are the least accurate
    w_end = int(round(END_WINDOW_CYCLES / fc0 / dt))
    resolved[:w_end] = False
    resolved[max(n - w_end, 0):] = False
    motion = SampledMotion.with_cutoff(t, x, fc)
    if sx > 0:
        # at rest (a dwell) the speed is below its noise: the friction law's sign there is
        # the noise's, not the rig's (a stuck rod holds any force below breakaway)
        s_v = float(np.std(SampledMotion.with_cutoff(t, e, fc).evaluate(t)[1]))
        resolved &= np.abs(motion.evaluate(t)[1]) > DWELL_THRESHOLD_SIGMA * s_v
    return MotionEstimate(motion, fc, resolved)


#: Fewest samples outside the unresolved windows a recorded test must keep to be fitted.
MIN_RESOLVED_SAMPLES = 20


def unresolved_tests(tests: Any, options: IdentifyOptions | None,
                     mass_kg: float | None) -> list[str]:
    """Recorded tests keeping fewer than :data:`MIN_RESOLVED_SAMPLES` samples, described
    (e.g. a fast stroke that is all reversal)."""
    out = []
    for t in tests:
        if t.excitation == "sine":
            continue
        n = int(estimate_motion(t, options, mass_kg).resolved.sum())
        if n < MIN_RESOLVED_SAMPLES:
            out.append(f"{t.file} keeps {n} of {t.n_samples} samples (< {MIN_RESOLVED_SAMPLES})")
    return out


def test_motion(test: BenchTest, options: IdentifyOptions | None = None,
                mass_kg: float | None = None) -> SampledMotion:
    """Prescribed motion of a test (:func:`estimate_motion`): smoothing spline of its
    measured displacement (with GCV: fitted to at most max(spline_points, n/10)
    uniformly decimated samples)."""
    return estimate_motion(test, options, mass_kg).motion
