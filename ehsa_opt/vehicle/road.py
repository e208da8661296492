"""Road input of the quarter car: ISO 8608 PSD, synthesis, measured profiles.

ISO 8608 displacement PSD (one-sided, in spatial frequency n, cycles/m)::

    G_d(n) = G_d(n0) (n / n0)^(−2),   n0 = 0.1 cycles/m

At speed V the temporal one-sided PSD is G(f) = G_d(f/V) / V (m²/Hz), so the
road *velocity* is white with one-sided PSD 4π² G_d(n0) n0² V (m²/s²/Hz).

**Factor-of-2 trap.**  A sum of cosines z(x) = Σ A_k cos(2π n_k x + φ_k) with
line spacing Δn has variance Σ A_k²/2; matching the *one-sided* PSD
(variance = ∫₀^∞ G_d dn) needs A_k = √(2 G_d(n_k) Δn).  Using √(G_d Δn) (the
two-sided convention) gives half the power.  :func:`octave_band_check` estimates
the PSD of a synthesised road and compares it with the target in octave bands.

Physical bound: for a linear quarter car with a pure-spring tyre on such a road
the mean power dissipated in the suspension is P = π² k1 G_d(n0) n0² V
(:func:`dissipation_bound_W`), whatever the masses, stiffness, damping and inertance.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from ..physics.params import ISO_CLASSES, ParameterError, RoadParams, VehicleParams

__all__ = ["N0_CYCLES_PER_M", "ROAD_BAND_CYCLES_PER_M", "road_psd_m3", "road_velocity_psd",
           "dissipation_bound_W", "RoadProfile", "synthesize_road", "load_profile_csv",
           "road_profile", "octave_band_check"]

#: Reference spatial frequency of ISO 8608, cycles/m.
N0_CYCLES_PER_M = 0.1
#: Spatial band synthesised and integrated over, cycles/m (an assumption: ISO 8608
#: classifies 0.011–2.83 cycles/m; we extend it to cover wheel hop at low speed and
#: the W_k band at high speed).
ROAD_BAND_CYCLES_PER_M: tuple[float, float] = (0.01, 10.0)


def _roughness(iso_class: str | float) -> float:
    if isinstance(iso_class, str):
        key = iso_class.strip().upper()
        if key not in ISO_CLASSES:
            raise ParameterError(f"road: iso_class '{iso_class}' is not an ISO 8608 class; use one "
                                 f"of {', '.join(ISO_CLASSES)}")
        return ISO_CLASSES[key]
    value = float(iso_class)
    if not value > 0.0:
        raise ParameterError(f"road: roughness G_d(n0) must be > 0 m³, got {value}")
    return value


def road_psd_m3(n_cycles_per_m: ArrayLike, iso_class: str | float) -> np.ndarray:
    """ISO 8608 one-sided displacement PSD G_d(n), m³ (m² per cycle/m).

    Parameters
    ----------
    n_cycles_per_m : array_like
        Spatial frequency, cycles/m (> 0).
    iso_class : str or float
        Class letter 'A' … 'H' (class mean) or G_d(n0) itself in m³.
    """
    n = np.asarray(n_cycles_per_m, dtype=float)
    return _roughness(iso_class) * (n / N0_CYCLES_PER_M) ** -2


def road_velocity_psd(road: RoadParams) -> float:
    """One-sided PSD of the road vertical velocity, (m/s)²/Hz: 4π² G_d(n0) n0² V."""
    return 4.0 * math.pi ** 2 * road.roughness_m3 * N0_CYCLES_PER_M ** 2 * road.speed_m_per_s


def dissipation_bound_W(vehicle: VehicleParams, road: RoadParams) -> float | None:
    """Mean power a linear quarter car dissipates on an ISO 8608 road, W.

    P = π² k1 G_d(n0) n0² V (independent of everything but the tyre stiffness);
    ``None`` for a measured profile (no PSD model).
    """
    if road.profile_csv is not None:
        return None
    return (math.pi ** 2 * vehicle.tyre_stiffness_N_per_m * road.roughness_m3
            * N0_CYCLES_PER_M ** 2 * road.speed_m_per_s)


# --------------------------------------------------------------------------- profiles
@dataclass(frozen=True)
class RoadProfile:
    """A road elevation sampled uniformly in time at the vehicle speed.

    Attributes
    ----------
    time_s, elevation_m : ndarray
        Time (s) and road elevation x0 (m), uniform sampling.
    speed_m_per_s : float
        Vehicle speed.
    sample_rate_hz : float
        Samples per second.
    source : str
        'ISO 8608 class C, seed 0' or the CSV path.
    band_cycles_per_m : tuple or None
        Synthesised spatial band (None for measured profiles).
    """

    time_s: np.ndarray
    elevation_m: np.ndarray
    speed_m_per_s: float
    sample_rate_hz: float
    source: str
    band_cycles_per_m: tuple[float, float] | None = None

    @property
    def distance_m(self) -> np.ndarray:
        return self.time_s * self.speed_m_per_s


def synthesize_road(road: RoadParams, sample_rate_hz: float = 1000.0,
                    band_cycles_per_m: tuple[float, float] = ROAD_BAND_CYCLES_PER_M,
                    amplitudes: str = "deterministic") -> RoadProfile:
    """ISO 8608 road by a sum of cosines with seeded random phases.

    Lines at n_k = k/L inside the band, amplitudes √(2 G_d(n_k) Δn) (one-sided
    PSD), phases uniform from ``numpy.random.default_rng(road.seed)``; evaluated
    exactly on the time grid by an inverse FFT (the profile is L-periodic).

    ``amplitudes="deterministic"`` (the default) fixes every line's amplitude: the
    mean square of a linear response over one period is then the same for every seed
    (only the phases change), which is what makes the frictionless time domain equal
    the frequency path.  ``amplitudes="gaussian"`` draws each line's complex
    coefficient from a circular Gaussian of the same mean power (Rayleigh amplitude,
    uniform phase): the profile is then a sample of a stationary Gaussian road, and a
    metric varies between seeds as it would between stretches of a real road of that
    length (:mod:`ehsa_opt.vehicle.uncertainty`).

    Parameters
    ----------
    road : RoadParams
        Class, speed, length and seed.
    sample_rate_hz : float
        Samples per second (must resolve the band's top: > 2 n_max V).
    band_cycles_per_m : tuple
        Spatial band (n_min, n_max), cycles/m.
    """
    if road.profile_csv is not None:
        raise ValueError("synthesize_road: the road is a measured profile; use road_profile()")
    v = road.speed_m_per_s
    fs = float(sample_rate_hz)
    n_lo, n_hi = band_cycles_per_m
    if not 0.0 < n_lo < n_hi:
        raise ParameterError(f"road band {band_cycles_per_m} must satisfy 0 < n_min < n_max")
    if not fs > 2.0 * n_hi * v:
        raise ParameterError(
            f"simulation: sample_rate_hz = {fs:g} cannot resolve the road band up to {n_hi:g} "
            f"cycles/m at {v:.3g} m/s; use sample_rate_hz > {2.0 * n_hi * v:.0f}")
    length = road.length_m
    n_samples = int(round(length / v * fs))
    if n_samples < 16:
        raise ParameterError(f"road: length_m = {length:g} m is too short at this speed; "
                             "make the road longer")
    length = n_samples * v / fs  # exact period of the FFT grid
    dn = 1.0 / length
    k = np.arange(n_samples // 2 + 1)
    n = k * dn
    inband = (n >= n_lo) & (n <= n_hi)
    amp = np.zeros(k.size)
    amp[inband] = np.sqrt(2.0 * road_psd_m3(n[inband], road.roughness_m3) * dn)
    rng = np.random.default_rng(road.seed)
    if amplitudes == "deterministic":
        coef = amp * np.exp(1j * rng.uniform(0.0, 2.0 * math.pi, k.size))
    elif amplitudes == "gaussian":  # E|c|² = amp², as the deterministic lines
        coef = amp * (rng.standard_normal(k.size) + 1j * rng.standard_normal(k.size)) \
            / math.sqrt(2.0)
    else:
        raise ParameterError(f"road: amplitudes = {amplitudes!r}; use 'deterministic' or "
                             "'gaussian'")
    # irfft(c)[j] = (1/N) Σ_k c_k e^{i2πkj/N} (with the Hermitian half): ×N/2 for k ≠ 0.
    elevation = np.fft.irfft(coef, n_samples) * n_samples / 2.0
    time = np.arange(n_samples) / fs
    return RoadProfile(time, elevation, v, fs,
                       f"ISO 8608 class {road.iso_class}, seed {road.seed}"
                       + (", Gaussian amplitudes" if amplitudes == "gaussian" else ""),
                       (float(n_lo), float(n_hi)))


def load_profile_csv(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Read a measured road ``distance_m,elevation_m`` CSV strictly.

    Returns
    -------
    distance_m, elevation_m : ndarray
    Raises ``ParameterError`` naming the file, row and fix on a missing column,
    a non-number, NaN, or non-increasing distance.
    """
    path = Path(path)
    if not path.is_file():
        raise ParameterError(f"{path}: road profile CSV not found; check profile_csv (it is "
                             "relative to the problem file)")
    from ..utils.limits import MAX_CSV_FIELD_CHARS
    try:
        with path.open(newline="", encoding="utf-8-sig") as fh:
            rows = list(csv.reader(fh))
    except UnicodeDecodeError as exc:
        raise ParameterError(f"{path}: byte {exc.start} is not UTF-8 ({exc.reason}); save the "
                             f"road profile as UTF-8 (plain ASCII numbers), e.g. iconv -f latin1 "
                             f"-t utf-8") from None
    except csv.Error as exc:  # a field over the csv module's limit, a NUL, a bad quote
        raise ParameterError(f"{path}: not a CSV of numbers ({exc}); write two columns "
                             f"distance_m,elevation_m in metres") from None
    for r, row in enumerate(rows, start=1):
        long = next((c for c in row if len(c) > MAX_CSV_FIELD_CHARS), None)
        if long is not None:
            raise ParameterError(f"{path}: row {r}: a field of {len(long)} characters; write "
                                 f"two numbers distance_m,elevation_m per row")
    if not rows:
        raise ParameterError(f"{path}: empty file; expected header 'distance_m,elevation_m'")
    header = [h.strip() for h in rows[0]]
    for col in ("distance_m", "elevation_m"):
        if col not in header:
            raise ParameterError(f"{path}: missing column '{col}'; the header must be "
                                 "'distance_m,elevation_m' (metres)")
    i_d, i_e = header.index("distance_m"), header.index("elevation_m")
    dist, elev = [], []
    for r, row in enumerate(rows[1:], start=2):
        if not row or all(not c.strip() for c in row):
            continue
        try:
            d, e = float(row[i_d]), float(row[i_e])
        except (ValueError, IndexError):
            raise ParameterError(f"{path}: row {r}: not two numbers ({row!r}); write "
                                 "distance_m,elevation_m in metres") from None
        if not (math.isfinite(d) and math.isfinite(e)):
            raise ParameterError(f"{path}: row {r}: NaN or infinite value; remove or fill "
                                 "that row")
        if dist and not d > dist[-1]:
            raise ParameterError(f"{path}: row {r}: distance_m = {d:g} does not increase "
                                 f"(previous {dist[-1]:g}); sort the rows and drop duplicates")
        dist.append(d)
        elev.append(e)
    if len(dist) < 2:
        raise ParameterError(f"{path}: fewer than two data rows")
    return np.asarray(dist), np.asarray(elev)


def road_profile(road: RoadParams, sample_rate_hz: float = 1000.0,
                 base_dir: str | Path | None = None) -> RoadProfile:
    """The road as a time signal: synthesised (ISO class) or a measured CSV profile.

    A measured profile is resampled linearly at distance steps V/fs; its start
    is shifted to zero elevation mean.  ``profile_csv`` is resolved against
    ``base_dir`` (the problem file's folder) when relative.
    """
    if road.profile_csv is None:
        return synthesize_road(road, sample_rate_hz)
    path = Path(road.profile_csv)
    if base_dir is not None and not path.is_absolute():
        path = Path(base_dir) / path
    dist, elev = load_profile_csv(path)
    v = road.speed_m_per_s
    fs = float(sample_rate_hz)
    span = dist[-1] - dist[0]
    n_samples = int(math.floor(span / v * fs)) + 1
    if n_samples < 16:
        raise ParameterError(f"{path}: the profile ({span:g} m) is too short to simulate")
    if float(np.ptp(elev)) == 0.0:
        raise ParameterError(f"{path}: the profile is flat (every elevation_m is "
                             f"{elev[0]:g} m): the car would not move; give a measured profile")
    from .resources import check_simulation_resources
    try:  # span x sample rate, checked before the resampled road is allocated
        check_simulation_resources(None, fs, 0.0, 1, 1, duration_s=span / v)
    except ParameterError as exc:
        raise ParameterError(f"{path}: {exc}") from None
    t = np.arange(n_samples) / fs
    x0 = np.interp(dist[0] + v * t, dist, elev)
    return RoadProfile(t, x0 - x0.mean(), v, fs, str(path), None)


def octave_band_check(profile: RoadProfile, iso_class: str | float,
                      band_cycles_per_m: tuple[float, float] = (0.05, 5.0)) -> dict:
    """Compare the periodogram of a synthesised road with the ISO 8608 target.

    The one-sided periodogram (2|FFT|²/(N² Δn)) is summed in octave bands
    [n_c/√2, n_c √2) with centres n_c = 0.0625·2^k inside ``band_cycles_per_m``
    and compared with the integral of the target over the same lines.

    Returns
    -------
    dict
        ``centres_cycles_per_m``, ``ratio`` (synthesised/target power per band),
        ``max_abs_dev`` = max |ratio − 1|.
    """
    x = profile.elevation_m - profile.elevation_m.mean()
    n_samples = x.size
    dx = profile.speed_m_per_s / profile.sample_rate_hz
    length = n_samples * dx
    dn = 1.0 / length
    spec = np.fft.rfft(x)
    power = 2.0 * np.abs(spec) ** 2 / n_samples ** 2  # variance per line (one-sided)
    n = np.arange(spec.size) * dn
    centres, ratios = [], []
    nc = 0.0625
    while nc <= band_cycles_per_m[1] * 1.0001:
        if nc >= band_cycles_per_m[0] * 0.9999:
            sel = (n >= nc / math.sqrt(2)) & (n < nc * math.sqrt(2)) & (n > 0)
            if sel.any():
                target = float(np.sum(road_psd_m3(n[sel], iso_class) * dn))
                centres.append(nc)
                ratios.append(float(power[sel].sum()) / target)
        nc *= 2.0
    ratio = np.asarray(ratios)
    return {"centres_cycles_per_m": centres, "ratio": ratio.tolist(),
            "max_abs_dev": float(np.max(np.abs(ratio - 1.0))) if ratio.size else math.nan}
