"""Where do simulation and measurement disagree?  Residual maps and the statistics
that say where a residual is structured rather than noise.

Residuals are normalised by each channel's noise level (estimated from the
measured signal, :func:`~ehsa_opt.estimation.discrepancy.prepared.noise_std`), so pure
measurement noise has unit variance.  For each coordinate c (cycle phase,
displacement, velocity, direction, time since the last velocity reversal, rotor
angle, test) the residual is binned on c and

    R²_c = SS_between / SS_total          (variance explained by the bin means)

is compared with its noise floor (B − 1)/(N − 1) (what B bin means explain in
white noise) by the F statistic F = (SS_between/(B−1)) / (SS_within/(N−B)) and its
p-value.  Frequency content: the share of residual power at the excitation
harmonics k f (k = 1…K) against its noise floor (the share of those FFT bins).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np
from scipy import stats

from ...physics.motion import SineMotion
from .prepared import PreparedTest

__all__ = ["residual_spectrum", "CoordinateStat", "ChannelMap", "Localisation", "localise", "reversal_times",
           "COORDINATES", "stroke_window"]

#: Coordinates a residual is mapped against (name → unit).
COORDINATES: dict[str, str] = {
    "cycle_phase": "rad", "displacement": "m", "velocity": "m/s", "direction": "sign(v)",
    "time_since_reversal": "s", "rotor_angle": "rad (mod 2π)", "test": "test index",
}


@dataclass
class CoordinateStat:
    """Residual against one coordinate: bin centres and means, R² and its noise floor."""

    coordinate: str
    centres: np.ndarray
    means: np.ndarray
    counts: np.ndarray
    r2: float
    floor: float
    f_stat: float
    p_value: float

    @property
    def structured(self) -> bool:
        return self.p_value < 1e-3 and self.r2 > 3 * self.floor

    def as_dict(self) -> dict:
        return {"coordinate": self.coordinate, "r2": self.r2, "noise_floor": self.floor,
                "F": self.f_stat, "p_value": self.p_value, "structured": self.structured}


@dataclass
class ChannelMap:
    """Localisation of one channel (``force`` or ``voltage``)."""

    channel: str
    rms_normalised: float  # rms of residual / noise (1 = noise only)
    structured_fraction: float  # 1 − 1/mean(r²): share of residual energy beyond noise
    coordinates: dict[str, CoordinateStat]
    harmonic_share: float
    harmonic_floor: float
    per_test_rms: list[float]
    spectrum: dict = field(default_factory=dict)  # frequency coordinate (residual_spectrum)

    def ranking(self) -> list[CoordinateStat]:
        """Coordinates by excess variance explained (R² − floor), best first."""
        return sorted(self.coordinates.values(), key=lambda c: -(c.r2 - c.floor))

    def as_dict(self) -> dict:
        return {"channel": self.channel, "rms_normalised": self.rms_normalised,
                "structured_fraction": self.structured_fraction,
                "harmonic_share": self.harmonic_share, "harmonic_floor": self.harmonic_floor,
                "per_test_rms_normalised": self.per_test_rms,
                "frequency": self.spectrum,
                "coordinates": {k: v.as_dict() for k, v in self.coordinates.items()}}


@dataclass
class Localisation:
    """Residual maps of all channels (see module docstring)."""

    channels: dict[str, ChannelMap] = field(default_factory=dict)
    labels: list[str] = field(default_factory=list)

    def summary(self) -> str:
        lines = []
        for ch in self.channels.values():
            top = [c for c in ch.ranking() if c.structured][:3]
            where = ", ".join(f"{c.coordinate} (R² {c.r2:.2f} vs floor {c.floor:.3f})"
                              for c in top) or "nowhere beyond noise"
            sp = ch.spectrum
            freq = (f"; spectrum: peak {sp['peak_hz']:.0f} Hz, "
                    f"{100 * sp['share_above_hz']:.0f} % of the power above "
                    f"{sp['above_hz']:g} Hz" if sp else "")
            lines.append(f"{ch.channel}: rms {ch.rms_normalised:.2f}× noise, "
                         f"{100 * ch.structured_fraction:.0f} % structured; structured against "
                         f"{where}; harmonics {100 * ch.harmonic_share:.0f} % of power "
                         f"(floor {100 * ch.harmonic_floor:.0f} %){freq}")
        return "\n".join(lines)

    def as_dict(self) -> dict:
        return {k: v.as_dict() for k, v in self.channels.items()}


def residual_spectrum(prepared: Sequence[PreparedTest], residuals: Sequence[np.ndarray],
                      above_hz: float = 100.0, min_hz: float = 2.0) -> dict:
    """The frequency coordinate of a residual: Welch spectra of every test
    (segments of ≈ 2 s or the test, averaged with weights by length), the peak
    above ``min_hz`` and the share of the power above ``above_hz`` (default 100 Hz;
    capped below the Nyquist frequency).  A flexibility shows as a peak at its
    resonance, a cogging at its rotor harmonic, noise as a flat spectrum.

    Returns {"peak_hz", "peak_share" (power within ±10 % of the peak), "above_hz",
    "share_above_hz", "frequency_hz" and "power" (the averaged spectrum)}; {}
    when no test has enough samples."""
    from scipy.signal import welch
    acc, freq, wsum = None, None, 0.0
    for pt, r in zip(prepared, residuals):
        r = np.asarray(r, float)
        if r.size < 64:
            continue
        fs = 1.0 / float(np.median(np.diff(pt.time_s)))
        nper = int(min(r.size, 2 ** int(np.log2(max(64, 2 * fs)))))
        f, P = welch(r - r.mean(), fs=fs, nperseg=nper)
        if freq is None:
            freq, acc = f, np.zeros_like(P)
        if f.size != freq.size or not np.allclose(f, freq):
            P = np.interp(freq, f, P, left=0.0, right=0.0)
        acc += r.size * P
        wsum += r.size
    if freq is None or wsum == 0 or not np.any(acc):
        return {}
    P = acc / wsum
    above = float(min(above_hz, 0.5 * freq[-1]))
    band = freq >= min_hz
    k = int(np.argmax(np.where(band, P, -np.inf)))
    near = np.abs(freq - freq[k]) <= 0.1 * freq[k]
    tot = float(P[band].sum())
    return {"peak_hz": float(freq[k]), "peak_share": float(P[near & band].sum() / tot),
            "above_hz": above, "share_above_hz": float(P[freq > above].sum() / tot),
            "frequency_hz": freq.tolist(), "power": P.tolist()}


def reversal_times(t: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Time since the last sign change of ``v`` (NaN before the first one)."""
    s = np.sign(v)
    idx = np.flatnonzero(s[1:] * s[:-1] < 0) + 1
    out = np.full(t.shape, np.nan)
    if idx.size == 0:
        return out
    last = np.searchsorted(idx, np.arange(t.size), side="right") - 1
    ok = last >= 0
    out[ok] = t[ok] - t[idx[last[ok]]]
    return out


def _binned(c: np.ndarray, r: np.ndarray, edges: np.ndarray, name: str) -> CoordinateStat | None:
    ok = np.isfinite(c)
    c, r = c[ok], r[ok]
    if c.size < 20:
        return None
    k = np.clip(np.searchsorted(edges, c, side="right") - 1, 0, edges.size - 2)
    B = edges.size - 1
    counts = np.bincount(k, minlength=B).astype(float)
    sums = np.bincount(k, weights=r, minlength=B)
    means = np.divide(sums, counts, out=np.full(B, np.nan), where=counts > 0)
    used = counts > 0
    Bu = int(used.sum())
    mu = r.mean()
    ss_tot = float(np.sum((r - mu) ** 2))
    ss_b = float(np.sum(counts[used] * (means[used] - mu) ** 2))
    ss_w = max(ss_tot - ss_b, 1e-300)
    N = r.size
    if Bu < 2 or N <= Bu:
        return None
    F = (ss_b / (Bu - 1)) / (ss_w / (N - Bu))
    p = float(stats.f.sf(F, Bu - 1, N - Bu))
    return CoordinateStat(name, 0.5 * (edges[1:] + edges[:-1]), means, counts,
                          ss_b / ss_tot if ss_tot > 0 else 0.0, (Bu - 1) / (N - 1), float(F), p)


def _harmonic_share(pts: Sequence[PreparedTest], res: Sequence[np.ndarray],
                    n_harm: int = 15) -> tuple[float, float]:
    """Share of residual power at the excitation harmonics, and the noise floor."""
    p_h = p_all = n_h = n_all = 0.0
    for pt, r in zip(pts, res):
        if not isinstance(pt.motion, SineMotion):
            continue
        dt = float(np.median(np.diff(pt.time_s)))
        X = np.abs(np.fft.rfft(r - r.mean())) ** 2
        fr = np.fft.rfftfreq(r.size, dt)
        df = fr[1] - fr[0]
        f0 = pt.motion.frequency_hz
        mask = np.zeros(fr.size, bool)
        for k in range(1, n_harm + 1):
            mask |= np.abs(fr - k * f0) <= 0.51 * df
        p_h += X[mask].sum()
        p_all += X[1:].sum()
        n_h += mask.sum()
        n_all += fr.size - 1
    if p_all <= 0:
        return math.nan, math.nan
    return float(p_h / p_all), float(n_h / n_all)


def localise(prepared: Sequence[PreparedTest], predictions: Sequence[np.ndarray], *,
             lead_m_per_rad: float, bins: int = 24) -> Localisation:
    """Map the normalised residuals (measured − simulated)/σ against the coordinates.

    Parameters
    ----------
    prepared : list of PreparedTest
    predictions : list of ndarray (ny, N)
        Simulated outputs of each test (e.g. :func:`~ehsa_opt.estimation.discrepancy.rig.predict`).
    lead_m_per_rad : float
        r, to form the rotor angle θ = x/r.
    bins : int
        Bins per continuous coordinate.
    """
    names = ["force", "voltage"]
    loc = Localisation(labels=[pt.test.label for pt in prepared])
    ny = min(p.shape[0] for p in predictions)
    for ch in range(ny):
        res, coords = [], {k: [] for k in COORDINATES}
        per_test = []
        for k, (pt, yp) in enumerate(zip(prepared, predictions)):
            r = (pt.y[ch] - yp[ch]) * pt.wnorm[ch]
            res.append(r)
            per_test.append(float(np.sqrt(np.mean(r ** 2))))
            x, v, _ = pt.u
            if isinstance(pt.motion, SineMotion):
                ph = np.mod(2 * np.pi * pt.motion.frequency_hz * pt.time_s + pt.motion.phase_rad,
                            2 * np.pi)
            else:
                ph = np.full(x.shape, np.nan)
            coords["cycle_phase"].append(ph)
            coords["displacement"].append(x)
            coords["velocity"].append(v)
            coords["direction"].append(np.sign(v))
            coords["time_since_reversal"].append(reversal_times(pt.time_s, v))
            coords["rotor_angle"].append(np.mod(x / lead_m_per_rad, 2 * np.pi))
            coords["test"].append(np.full(x.shape, float(k)))
        r_all = np.concatenate(res)
        stats_: dict[str, CoordinateStat] = {}
        for name in COORDINATES:
            c = np.concatenate(coords[name])
            fin = c[np.isfinite(c)]
            if fin.size < 20:
                continue
            if name == "direction":
                edges = np.array([-1.5, -0.5, 0.5, 1.5])
            elif name == "test":
                edges = np.arange(len(prepared) + 1) - 0.5
            elif name == "cycle_phase" or name == "rotor_angle":
                edges = np.linspace(0, 2 * np.pi, bins + 1)
            elif name == "time_since_reversal":
                hi = float(np.nanpercentile(fin, 99.5))
                edges = np.concatenate([[0.0], np.geomspace(max(hi, 1e-2) * 1e-3, hi, bins)])
                edges[-1] = np.inf
            else:
                lo, hi = np.percentile(fin, [0.5, 99.5])
                edges = np.linspace(lo, hi, bins + 1)
                edges[0], edges[-1] = -np.inf, np.inf
            st = _binned(c, r_all, edges, name)
            if st is not None:
                if name in ("displacement", "velocity"):
                    lo, hi = np.percentile(fin, [0.5, 99.5])
                    st.centres = np.linspace(lo, hi, bins + 1)[:-1] + 0.5 * (hi - lo) / bins
                if name == "time_since_reversal":
                    st.centres = np.sqrt(np.maximum(edges[:-1], 1e-6)
                                         * np.where(np.isfinite(edges[1:]), edges[1:], hi))
                stats_[name] = st
        h, hf = _harmonic_share(prepared, res)
        ms = float(np.mean(r_all ** 2))
        loc.channels[names[ch]] = ChannelMap(names[ch], math.sqrt(ms),
                                             max(0.0, 1 - 1 / ms) if ms > 0 else 0.0,
                                             stats_, h, hf, per_test,
                                             residual_spectrum(prepared, res))
    return loc


def rotor_angle_spectrum(prepared: Sequence[PreparedTest], predictions: Sequence[np.ndarray], *,
                         lead_m_per_rad: float, max_periods: int = 24) -> np.ndarray:
    """Share of the force residual explained by sin/cos(k θ), k = 1 … ``max_periods``.

    θ = x/r (rigid screw).  Each k's pair of columns is fitted alone (per test a
    mean is removed first), so entry k − 1 is the variance share of that period —
    the spectrum in rotor angle used to pick the cogging period.
    """
    r_all, th_all = [], []
    for pt, yp in zip(prepared, predictions):
        r = (pt.y[0] - yp[0]) * pt.wnorm[0]
        r_all.append(r - r.mean())
        th_all.append(pt.u[0] / lead_m_per_rad)
    r, th = np.concatenate(r_all), np.concatenate(th_all)
    tot = float(r @ r) or 1.0
    out = np.zeros(max_periods)
    for k in range(1, max_periods + 1):
        A = np.column_stack([np.sin(k * th), np.cos(k * th)])
        coef, *_ = np.linalg.lstsq(A, r, rcond=None)
        out[k - 1] = float(np.sum((A @ coef) ** 2)) / tot
    return out


def best_rotor_period(prepared: Sequence[PreparedTest], predictions: Sequence[np.ndarray], *,
                      lead_m_per_rad: float, max_periods: int = 24) -> int:
    """The k (periods per rotor revolution) with the largest share in
    :func:`rotor_angle_spectrum`."""
    return int(np.argmax(rotor_angle_spectrum(prepared, predictions,
                                              lead_m_per_rad=lead_m_per_rad,
                                              max_periods=max_periods))) + 1


def stroke_window(prepared: Sequence[PreparedTest], predictions: Sequence[np.ndarray], *,
                  smoothing_m_per_s: float = 1e-3, edge_sharpness: float = 8.0,
                  n_centres: int = 41, widths_rel: Sequence[float] = (0.05, 0.08, 0.12, 0.18,
                                                                     0.27, 0.4, 0.6, 0.9)
                  ) -> tuple[float, float] | None:
    """Centre and width (m) of the stroke window where the force residual looks like
    friction: the start of :class:`~ehsa_opt.physics.components.PositionFriction`.

    The normalised force residual is regressed on [tanh(v/u_s), w(x; x_c, L) tanh(v/u_s)]
    (the first column is the Coulomb level a baseline refit would move anyway) for
    x_c on ``n_centres`` points of the stroke and L = ``widths_rel`` × stroke; the
    (x_c, L) whose window column removes the most residual energy wins.  None when
    the stroke is shorter than 0.1 mm.
    """
    xs, rs, ss = [], [], []
    for pt, yp in zip(prepared, predictions):
        xs.append(pt.u[0])
        ss.append(np.tanh(pt.u[1] / smoothing_m_per_s))
        rs.append((pt.y[0] - yp[0]) * pt.wnorm[0])
    x, r, sg = np.concatenate(xs), np.concatenate(rs), np.concatenate(ss)
    lo, hi = float(x.min()), float(x.max())
    stroke = hi - lo
    if not stroke > 1e-4:
        return None
    q0 = sg / (np.linalg.norm(sg) or 1.0)
    r_perp = r - q0 * (q0 @ r)
    best, out = -1.0, None
    for L in np.asarray(widths_rel) * stroke:
        for xc in np.linspace(lo, hi, n_centres):
            z = (x - xc) / (0.5 * L)
            c = 0.5 * (np.tanh(edge_sharpness * (z + 1)) - np.tanh(edge_sharpness * (z - 1))) * sg
            c = c - q0 * (q0 @ c)
            nn = float(c @ c)
            if nn <= 1e-12 * x.size:
                continue
            gain = float(c @ r_perp) ** 2 / nn
            if gain > best:
                best, out = gain, (float(xc), float(L))
    return out
