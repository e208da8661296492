"""Physics checks of bench data: do the signals agree with ``bench.toml``?

The loader in :mod:`.bench_format` checks syntax (columns, numbers, increasing time).
These checks look at what the numbers *mean*, with stated tolerances:

* **Ranges** (every test): |force| <= :data:`MAX_FORCE_N` (1e308 is a corrupt
  sample), force and displacement not constant (an all-zero column), a force
  swing of at least :data:`MIN_FORCE_SWING_N` when the rod moves (a smaller one is
  almost surely kN), a sample rate of at least :data:`MIN_SAMPLE_RATE_HZ` (a
  lower one is almost surely time in ms).
* **Sine tests**: a sine is fitted to the displacement (FFT peak, refined by a
  variable-projection least-squares search over the frequency).  The fitted
  frequency must be within :data:`TOLERANCES` ``frequency`` (2 %) of
  ``frequency_hz``, the amplitude within 10 % of ``amplitude_m``, the sine must
  explain the signal (relative residual <= 20 %), and the sample rate must give
  at least :data:`MIN_SAMPLES_PER_CYCLE` samples per cycle.
* **Consistency with the harvester** (sine tests; the harvester of ``bench.toml``):
  the voltage must match the open-circuit EMF K_e ω, ω = v / r, through the load
  divider R_e / (R_e + R_i) within 15 % (mV or a wrong ``load_ohm`` fails); the
  force, regressed on the inerter and damping it implies
  (m_eq a + c_eq v, plus a Coulomb-like sign(v) term and an offset for the
  unknown friction), must carry a gain between 1/5 and 5 (kN or N·1000 fail).
  The force check runs only when the rig has a generator or ``bench.toml`` gives a
  ``[harvester]`` table (otherwise the Table 1 inertia does not describe the rig).

Tolerances were set on the embedded prototype data (gains 0.65–1.06 for force,
1.000–1.008 for voltage) and are checked on generated data with other seeds,
effects and grids, and on the EMPS data (``validation/bench_checks_heldout.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import minimize_scalar

from ..physics.params import HarvesterParams

__all__ = ["SineEstimate", "estimate_sine", "check_test_signals", "TOLERANCES", "MAX_FORCE_N",
           "MIN_FORCE_SWING_N", "MIN_SAMPLE_RATE_HZ", "MIN_SAMPLES_PER_CYCLE"]

#: Relative tolerances of the sine-test checks (see the module docstring).
TOLERANCES = {
    "frequency": 0.02,        # |f_fit / frequency_hz - 1|
    "amplitude": 0.10,        # |A_fit / amplitude_m - 1|
    "sine_residual": 0.20,    # rms(x - sine) / A_fit
    "voltage_gain": 0.15,     # |V / (K_e ω R_e/(R_e+R_i)) - 1|
    "force_gain": 5.0,        # 1/5 <= F gain on m_eq a + c_eq v <= 5
}
#: Largest plausible bench force, N.
MAX_FORCE_N = 1e6
#: Smallest plausible peak-to-peak force swing when the rod moves, N.
MIN_FORCE_SWING_N = 1.0
#: Smallest plausible sample rate of a damper bench, Hz.
MIN_SAMPLE_RATE_HZ = 20.0
#: Samples per excitation cycle needed to resolve the friction switch.
MIN_SAMPLES_PER_CYCLE = 20.0
_MAX_FIT_SAMPLES = 200_000  # sine fits use at most this many (strided) samples


@dataclass(frozen=True)
class SineEstimate:
    """A least-squares sine x ≈ a sin ωt + b cos ωt + c.

    Attributes
    ----------
    frequency_hz, amplitude_m, offset_m : float
    relative_residual : float
        rms(x − fit) / amplitude.
    sin_coef, cos_coef : float
    """

    frequency_hz: float
    amplitude_m: float
    offset_m: float
    relative_residual: float
    sin_coef: float
    cos_coef: float

    def velocity(self, t: np.ndarray) -> np.ndarray:
        w = 2.0 * math.pi * self.frequency_hz
        return w * (self.sin_coef * np.cos(w * t) - self.cos_coef * np.sin(w * t))

    def acceleration(self, t: np.ndarray) -> np.ndarray:
        w = 2.0 * math.pi * self.frequency_hz
        return -w * w * (self.sin_coef * np.sin(w * t) + self.cos_coef * np.cos(w * t))


def _fit_at(t: np.ndarray, x: np.ndarray, f: float) -> tuple[float, np.ndarray]:
    w = 2.0 * math.pi * f
    basis = np.column_stack([np.sin(w * t), np.cos(w * t), np.ones_like(t)])
    coef, *_ = np.linalg.lstsq(basis, x, rcond=None)
    r = x - basis @ coef
    return float(r @ r), coef


def estimate_sine(time_s: np.ndarray, x: np.ndarray) -> SineEstimate:
    """Frequency, amplitude and fit quality of the dominant sine in ``x``.

    The periodogram peak (Hann window) gives a start; a bounded scalar search of
    the least-squares residual over ±1.5 frequency bins refines it.
    """
    step = max(1, time_s.size // _MAX_FIT_SAMPLES)
    t, xs = time_s[::step] - time_s[0], x[::step]
    n = t.size
    dt = float(np.median(np.diff(t)))
    spec = np.abs(np.fft.rfft((xs - xs.mean()) * np.hanning(n)))
    freqs = np.fft.rfftfreq(n, dt)
    k = int(np.argmax(spec[1:])) + 1
    df = freqs[1]
    lo, hi = max(freqs[k] - 1.5 * df, 0.25 * df), freqs[k] + 1.5 * df
    best = minimize_scalar(lambda f: _fit_at(t, xs, f)[0], bounds=(lo, hi), method="bounded",
                           options={"xatol": 1e-6 * freqs[k]})
    f = float(best.x)
    rss, coef = _fit_at(t, xs, f)
    amp = math.hypot(coef[0], coef[1])
    rel = math.sqrt(rss / n) / amp if amp > 0 else math.inf
    return SineEstimate(f, amp, float(coef[2]), rel, float(coef[0]), float(coef[1]))


def _row(values: np.ndarray) -> int:
    """1-based CSV row (header = 1) of the largest |value|."""
    return int(np.argmax(np.abs(values))) + 2


def check_test_signals(test, harvester: HarvesterParams, *, has_generator: bool,
                       harvester_given: bool) -> list[str]:
    """Problems of one test's signals against ``bench.toml``; empty when consistent.

    Parameters
    ----------
    test : BenchTest
    harvester : HarvesterParams
        The ``[harvester]`` of ``bench.toml`` (Table 1 defaults otherwise).
    has_generator : bool
    harvester_given : bool
        ``bench.toml`` has a ``[harvester]`` table (enables the force check on rigs
        without a generator).

    Returns
    -------
    list of str
        Messages naming the file, the row or key, what was expected and the fix.
    """
    name = test.file
    t, x, F, V = test.time_s, test.displacement_m, test.force_N, test.voltage_V
    out: list[str] = []
    fmax = float(np.max(np.abs(F)))
    if fmax > MAX_FORCE_N:
        out.append(f"{name}: row {_row(F)}, column 'force_N': |F| = {fmax:.3g} N is beyond any "
                   f"bench (<= {MAX_FORCE_N:.0e} N expected); repair or remove that sample")
    if np.ptp(x) == 0.0:
        out.append(f"{name}: column 'displacement_m' is constant ({x[0]:g}); the rod never "
                   f"moves — is the column empty or the sensor unplugged? Record the motion")
    if np.ptp(F) == 0.0:
        out.append(f"{name}: column 'force_N' is constant ({F[0]:g}); a moving damper needs a "
                   f"force — is the load-cell channel empty? Record the force")
    dt = float(np.median(np.diff(t)))
    fs = 1.0 / dt
    if fs < MIN_SAMPLE_RATE_HZ:
        out.append(f"{name}: column 'time_s': median step {dt:g} s ({fs:.3g} Hz) is too slow for "
                   f"a damper bench (>= {MIN_SAMPLE_RATE_HZ:g} Hz expected); is time in ms? "
                   f"Convert it to seconds (divide by 1000)")
    if out:
        return out  # the estimates below would be meaningless
    swing = float(np.percentile(F, 99.5) - np.percentile(F, 0.5))
    if swing < MIN_FORCE_SWING_N and np.ptp(x) > 1e-4:
        out.append(f"{name}: column 'force_N' swings only {swing:.3g} N while the rod moves "
                   f"{1e3 * np.ptp(x):.3g} mm (>= {MIN_FORCE_SWING_N:g} N expected); is force "
                   f"in kN? Convert it to newtons (multiply by 1000)")
    if test.excitation != "sine" or test.frequency_hz is None:
        return out
    f_decl, a_decl = test.frequency_hz, test.amplitude_m
    key = f"bench.toml [[test]] ({name})"
    if fs < MIN_SAMPLES_PER_CYCLE * f_decl:
        out.append(f"{name}: sampled at {fs:.4g} Hz, only {fs / f_decl:.1f} samples per cycle of "
                   f"the declared {f_decl:g} Hz (>= {MIN_SAMPLES_PER_CYCLE:g} needed, i.e. >= "
                   f"{MIN_SAMPLES_PER_CYCLE * f_decl:.4g} Hz); record at a higher rate or check "
                   f"'frequency_hz' in {key}")
        return out
    span_s = t[-1] - t[0] + 1.0 / fs          # N samples cover N sample intervals
    if span_s * f_decl < 1.0 - 1e-6:
        out.append(f"{name}: {span_s:.3g} s of data hold less than one cycle of the "
                   f"declared {f_decl:g} Hz; record at least one full cycle or check "
                   f"'frequency_hz' in {key}")
        return out
    est = estimate_sine(t, x)
    tol = TOLERANCES
    if abs(est.frequency_hz / f_decl - 1.0) > tol["frequency"]:
        out.append(f"{name}: the displacement oscillates at {est.frequency_hz:.4g} Hz but "
                   f"{key} declares frequency_hz = {f_decl:g} (tolerance "
                   f"{100 * tol['frequency']:g} %); fix 'frequency_hz' or the time column")
        return out
    if est.relative_residual > tol["sine_residual"]:
        out.append(f"{name}: the displacement is not a sine (rms residual "
                   f"{100 * est.relative_residual:.0f} % of the amplitude, <= "
                   f"{100 * tol['sine_residual']:g} % expected); set excitation = \"recorded\" in "
                   f"{key} or check the column")
        return out
    if a_decl is not None and abs(est.amplitude_m / a_decl - 1.0) > tol["amplitude"]:
        out.append(f"{name}: the displacement amplitude is {est.amplitude_m:.4g} m but {key} "
                   f"declares amplitude_m = {a_decl:g} (tolerance {100 * tol['amplitude']:g} %); "
                   f"fix 'amplitude_m' or the displacement unit (metres)")
    tt = t - t[0]
    v = est.velocity(tt)
    a = est.acceleration(tt)
    r = harvester.lead_m_per_rad
    w = 2.0 * math.pi * est.frequency_hz
    if V is not None and test.load_ohm is not None and math.isfinite(test.load_ohm):
        re, ri = test.load_ohm, harvester.internal_resistance_ohm
        pred = harvester.voltage_constant_Vs_per_rad * (v / r) * re / (re + ri)
        norm = float(pred @ pred)
        gain = float(pred @ V) / norm if norm > 0 and math.isfinite(norm) else math.nan
        if not math.isfinite(gain):
            out.append(f"{name}: load_ohm = {re:g} in {key} makes the voltage that the motion "
                       f"implies (K_e·ω·R_e/(R_e+R_i)) vanish or overflow, while column "
                       f"'voltage_V' is measured; check 'load_ohm' (in ohm)")
        elif abs(gain - 1.0) > tol["voltage_gain"]:
            hint = ("is voltage in mV? Convert it to volts" if gain > 100 else
                    "is voltage in kV? Convert it to volts" if 0 < gain < 0.01 else
                    f"check 'load_ohm' in {key}, the [harvester] constants (K_e, R_i, lead) "
                    f"or the voltage channel")
            out.append(f"{name}: column 'voltage_V' is {gain:.3g} × the voltage "
                       f"K_e·ω·R_e/(R_e+R_i) "
                       f"that the motion implies (ω = v/r, load_ohm = {re:g}; expected within "
                       f"{100 * tol['voltage_gain']:g} %); {hint}")
    if has_generator or harvester_given:
        c_eq = (harvester.equivalent_damping_Ns_per_m(w, test.load_ohm)
                if has_generator and test.load_ohm is not None else 0.0)
        dyn = harvester.equivalent_mass_kg() * a + c_eq * v
        vscale = max(1e-3 * float(np.max(np.abs(v))), 1e-9)
        basis = np.column_stack([dyn, np.tanh(v / vscale), np.ones_like(v)])
        coef, *_ = np.linalg.lstsq(basis, F, rcond=None)
        gain = float(coef[0])
        g = tol["force_gain"]
        if not 1.0 / g <= gain <= g:
            hint = ("is force in kN? Convert it to newtons" if 0 < gain < 0.01 else
                    "is force in mN or the sign reversed? Use newtons, positive in compression"
                    if gain > 100 or gain < 0 else
                    f"check the [harvester] constants (inertia, lead, K_e, K_t) and "
                    f"'load_ohm' in {key}")
            out.append(f"{name}: column 'force_N' follows the inerter and damping of the harvester "
                       f"(m_eq·a + c_eq·v) with gain {gain:.3g} (between {1 / g:g} and {g:g} "
                       f"expected); {hint}")
    return out
