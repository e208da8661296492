"""The rod friction as a regression on the bench samples, and its uncertainty with the
effective sample size of autocorrelated residuals.

On a rigid bench the rod motion is prescribed, so the measured force is the frictionless
model force (inertia, generator, rig terms: one simulation with the friction set to zero)
plus the rod friction F_rod(v(t); θ) = F_ns(v) + T_b(v/r)/r at the measured stroke
velocity.  The *friction samples* y(t) = F_e(t) − F_0(t) against v(t) are therefore a
non-linear regression in the eight friction parameters θ, and the uncertainty of any
friction value follows from the sandwich covariance

    Σ = B⁺ M B⁺,   B = JᵀJ,   M = Σ_tests Σ_|l|≤L w_l Σ_t s_t s_{t−l}ᵀ,   s_t = J_t e_t

with e the residuals at the fitted θ and Bartlett weights w_l = 1 − |l|/(L+1) (Newey and
West 1987).  The bandwidth L of each test is Andrews' (1991) AR(1) plug-in on that test's
residuals: time-series residuals are strongly autocorrelated (a model error repeats every
cycle, the noise is filtered), and i.i.d. samples would make the band several times too
narrow (``tests/estimation/test_rod_law.py`` checks the coverage of both on an AR(1) regression).
Tests are independent of each other.  B⁺ is the pseudo-inverse with the identifiability
threshold: the nut/bearing split is not determined by a rigid bench, and any friction *at the
rod* has (almost) no component along it.

Beside it the cluster-robust sandwich (every test one cluster: valid for any correlation
within a test, including a model error repeated in every cycle, which no bandwidth shorter
than the test captures).  The fitted law's 95 % band at a velocity v is
F_rod(v; θ̂) ± h(v), h the larger of 1.96 √(g(v)ᵀ Σ_NW g(v)) and t_{G−1} √(g(v)ᵀ Σ_cl g(v))
(G tests, at least four for the cluster-robust one), g the gradient of F_rod(v) in θ: inside the data it is as narrow as the data make it, beyond the
data it widens as the Fisher uncertainty of the law's high-velocity part (the viscous
coefficient and the Coulomb level) does.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import numpy as np

from ..physics.friction import rod_friction_N
from ..physics.params import FRICTION_NAMES, ParameterError

__all__ = ["FrictionSamples", "RodLawFit", "friction_samples", "rod_law_fit",
           "hac_covariance", "cluster_covariance", "andrews_bandwidth", "rod_gradient",
           "Z95"]
#: Fewest tests for the cluster-robust covariance.
_MIN_CLUSTERS = 4

#: Two-sided 95 % normal quantile.
Z95 = 1.959963984540054
#: Scales of the eight friction parameters (finite differences, conditioning).
_SCALE = {"nut_breakaway_N": 10.0, "nut_coulomb_N": 10.0,
          "nut_breakaway_velocity_m_per_s": 1e-2, "nut_viscous_Ns_per_m": 100.0,
          "bearing_breakaway_Nm": 1e-2, "bearing_coulomb_Nm": 1e-2,
          "bearing_breakaway_velocity_rad_per_s": 1.0, "bearing_viscous_Nms_per_rad": 1e-5}


@dataclass
class FrictionSamples:
    """Per test: stroke velocity (m/s) and friction force at the rod (N), end-trimmed, and
    (optional) the stroke acceleration (m/s²) on the same samples."""

    files: list[str]
    velocity_m_per_s: list[np.ndarray]
    friction_N: list[np.ndarray]
    acceleration_m_per_s2: list[np.ndarray] | None = None

    def __len__(self) -> int:
        return len(self.files)

    def peak_velocity_m_per_s(self) -> np.ndarray:
        """99th percentile of |v| of every test."""
        return np.array([float(np.percentile(np.abs(v), 99.0)) for v in self.velocity_m_per_s])

    def peak_acceleration_m_per_s2(self) -> np.ndarray:
        """99th percentile of |a| of every test (NaN without accelerations)."""
        if self.acceleration_m_per_s2 is None:
            return np.full(len(self.files), np.nan)
        return np.array([float(np.percentile(np.abs(a), 99.0))
                         for a in self.acceleration_m_per_s2])


def friction_samples(data: Any, parameters: Mapping[str, float] | None = None,
                     options: Any = None, tests: Sequence[Any] | None = None
                     ) -> FrictionSamples:
    """Friction samples of a bench campaign on the rigid model: every sample of a sine
    test (ends trimmed), the resolved samples of a recorded motion (outside its reversal
    and dwell windows, :func:`~ehsa_opt.estimation.identify_options.estimate_motion`).

    Parameters
    ----------
    data : BenchData
    parameters : mapping, optional
        Fitted parameters; those that are not friction (inertia, offset of a rig without
        generator) enter the frictionless model force.
    options : IdentifyOptions, optional
        Motion smoothing and end trimming (as the identification).
    tests : sequence of BenchTest, optional
        A subset (default every test).
    """
    from .test_simulation import simulate_tests
    from .identify_options import IdentifyOptions, estimate_motion, test_motion
    opt = options or IdentifyOptions.for_rig(data.has_generator)
    tests = list(tests if tests is not None else data.tests)
    other = {k: float(v) for k, v in (parameters or {}).items()
             if k not in FRICTION_NAMES and k != "load_ohm" and v is not None}
    preds = simulate_tests(tests, data.harvester, other, has_generator=data.has_generator,
                           options=opt)
    mass = data.harvester.equivalent_mass_kg() if data.has_generator else None
    vs, ys, acc = [], [], []
    for test, pr in zip(tests, preds):
        n = test.n_samples
        k = int(round(opt.trim_fraction * n))
        keep = np.zeros(n, bool)
        keep[k:n - k] = True
        if getattr(test, "excitation", "sine") != "sine":
            # a recorded motion's reversal (corner) and dwell windows are not resolved:
            # there the force is the corner's inertia and impacts, which no function of
            # the velocity gives (the fits weight them out too); a stroke with no resolved
            # sample keeps them rather than nothing
            resolved = estimate_motion(test, opt, mass).resolved
            if np.count_nonzero(keep & resolved) >= 10:
                keep &= resolved
        _, v, a = test_motion(test, opt).evaluate(test.time_s)[:3]
        vs.append(np.asarray(v[keep], dtype=float))
        acc.append(np.asarray(a[keep], dtype=float))
        ys.append(np.asarray(test.force_N[keep] - pr.force_N[keep], dtype=float))
    return FrictionSamples([t.file for t in tests], vs, ys, acc)


def rod_gradient(v: np.ndarray, params: Mapping[str, float], names: Sequence[str],
                 lead_m_per_rad: float) -> np.ndarray:
    """d F_rod(v) / d θ (len(v) × len(names)) by central differences."""
    v = np.asarray(v, dtype=float)
    base = [float(params[n]) for n in FRICTION_NAMES]
    G = np.empty((v.size, len(names)))
    for j, n in enumerate(names):
        i = FRICTION_NAMES.index(n)
        h = 1e-6 * max(abs(base[i]), _SCALE[n])
        lo, hi = list(base), list(base)
        if "velocity" in n:  # stay positive
            h = min(h, 0.5 * base[i])
        lo[i] -= h
        hi[i] += h
        G[:, j] = (np.asarray(rod_friction_N(v, hi, lead_m_per_rad))
                   - np.asarray(rod_friction_N(v, lo, lead_m_per_rad))) / (2.0 * h)
    return G


def andrews_bandwidth(e: np.ndarray) -> int:
    """Bartlett-kernel bandwidth of Andrews (1991) with the AR(1) plug-in on ``e``."""
    e = np.asarray(e, dtype=float) - float(np.mean(e))
    n = e.size
    den = float(e[:-1] @ e[:-1])
    rho = float(e[1:] @ e[:-1]) / den if den > 0 else 0.0
    rho = min(max(rho, -0.999), 0.999)
    alpha = 4.0 * rho ** 2 / ((1.0 - rho) ** 2 * (1.0 + rho) ** 2)
    return int(min(max(math.ceil(1.1447 * (alpha * n) ** (1.0 / 3.0)), 0), n - 1))


def _pinv_scaled(B: np.ndarray, rcond: float) -> tuple[np.ndarray, int]:
    """Pseudo-inverse of a Gram matrix, threshold relative in column-normalised form."""
    d = np.sqrt(np.maximum(np.diag(B), 1e-300))
    Bs = B / np.outer(d, d)
    ev, V = np.linalg.eigh(0.5 * (Bs + Bs.T))
    keep = ev > rcond * max(float(ev.max()), 1e-300)
    return ((V[:, keep] / ev[keep]) @ V[:, keep].T) / np.outer(d, d), int(keep.sum())


def cluster_covariance(J_blocks: Sequence[np.ndarray], e_blocks: Sequence[np.ndarray],
                       rcond: float = 1e-6, leverage: bool = True,
                       max_leverage: float = 0.99) -> np.ndarray:
    """Cluster-robust sandwich with every block (test) one cluster: B⁺ M B⁺ with
    M = Σ_g J_gᵀ ẽ_g ẽ_gᵀ J_g — valid for any correlation within a test, including an
    error that repeats every cycle (a model error), which no bandwidth shorter than the
    test captures.

    ``leverage`` (default): ẽ_g = (I − H_gg)^(−1/2) e_g with H_gg = J_g B⁺ J_gᵀ, the
    bias-reduced (CR2, Bell and McCaffrey 2002) form.  The plain form (ẽ = e, scaled by
    G/(G−1)) is biased low when a few tests own a direction of the parameters — the one
    fast test that alone determines the viscous slope: the fit absorbs that test's error,
    its residuals come out small, and the band beyond the slow tests is too narrow.
    H_gg has rank ≤ p, so the correction is computed in p dimensions (thin SVD of J_g);
    its eigenvalues are capped at ``max_leverage`` (a test that alone determines a
    direction cannot show its own error at all: the cap keeps the band finite and wide).
    """
    B = sum(J.T @ J for J in J_blocks)
    G = len(J_blocks)
    Binv, _ = _pinv_scaled(B, rcond)
    M = np.zeros_like(B)
    for J, e in zip(J_blocks, e_blocks):
        e = np.asarray(e, dtype=float)
        if leverage and J.size:
            U, S, Vt = np.linalg.svd(J, full_matrices=False)
            K = (S[:, None] * (Vt @ Binv @ Vt.T)) * S[None, :]
            lam, Q = np.linalg.eigh(0.5 * (K + K.T))
            lam = np.clip(lam, 0.0, max_leverage)
            UQ = U @ Q
            e = e + UQ @ ((1.0 / np.sqrt(1.0 - lam) - 1.0) * (UQ.T @ e))
        sg = J.T @ e
        M += np.outer(sg, sg)
    scale = 1.0 if leverage else G / max(G - 1, 1)
    cov = Binv @ (M * scale) @ Binv
    return 0.5 * (cov + cov.T)


def hac_covariance(J_blocks: Sequence[np.ndarray], e_blocks: Sequence[np.ndarray],
                   rcond: float = 1e-6, bandwidths: Sequence[int] | None = None
                   ) -> tuple[np.ndarray, np.ndarray, list[int], list[float]]:
    """Newey–West sandwich covariance of a least-squares estimate from independent blocks.

    Parameters
    ----------
    J_blocks, e_blocks : sequences of arrays
        Per block (test) the Jacobian rows (n_i × p) and residuals (n_i), in time order.
    rcond : float
        Relative eigenvalue below which a direction of JᵀJ is dropped (pseudo-inverse).
    bandwidths : sequence of int, optional
        Per block; default :func:`andrews_bandwidth` of its residuals.

    Returns
    -------
    cov_hac, cov_iid : ndarray
        Sandwich covariance and the i.i.d. one (σ² B⁺).
    bandwidths : list of int
    n_effective : list of float
        Per block n / (1 + 2 Σ_l w_l ρ_l) of the residuals.
    """
    p = J_blocks[0].shape[1]
    B = np.zeros((p, p))
    M = np.zeros((p, p))
    sse, n_all, Ls, neff = 0.0, 0, [], []
    for k, (J, e) in enumerate(zip(J_blocks, e_blocks)):
        e = np.asarray(e, dtype=float)
        B += J.T @ J
        s = J * e[:, None]
        L = andrews_bandwidth(e) if bandwidths is None else int(bandwidths[k])
        S = s.T @ s
        ec = e - e.mean()
        g0 = float(ec @ ec)
        tau = 1.0
        for lag in range(1, L + 1):
            w = 1.0 - lag / (L + 1.0)
            G = s[lag:].T @ s[:-lag]
            S += w * (G + G.T)
            if g0 > 0:
                tau += 2.0 * w * float(ec[lag:] @ ec[:-lag]) / g0
        M += S
        Ls.append(L)
        neff.append(float(e.size / max(tau, 1.0)))
        sse += float(e @ e)
        n_all += e.size
    Binv, rank = _pinv_scaled(B, rcond)
    cov = Binv @ M @ Binv
    cov = 0.5 * (cov + cov.T)
    sigma2 = sse / max(n_all - rank, 1)
    return cov, sigma2 * Binv, Ls, neff


@dataclass
class RodLawFit:
    """A rod-friction law with its sandwich (HAC) covariance.

    Attributes
    ----------
    parameters : dict
        The eight friction values (the fitted law).
    free : list of str
        The parameters the covariance is over (the free ones of the law).
    covariance, covariance_iid : ndarray
        HAC and i.i.d. covariance of ``free`` (their units squared).
    lead_m_per_rad : float
    n_samples, n_effective : int, float
        Samples used and the effective sample size (sum over the tests).
    bandwidths : list of int
        Newey–West bandwidth per test (samples).
    residual_rms_N : float
    velocity_range_m_per_s : tuple
        Smallest and largest per-test 99th-percentile |v| of the samples.
    covariance_cluster : ndarray or None
        Cluster-robust covariance (tests as clusters; None with fewer than four tests).
    n_tests : int
    test_residual_rms_N, test_peak_acceleration_m_per_s2 : list of float
        Per test: rms of its residuals and the 99th percentile of its |stroke
        acceleration| (NaN when unknown) — how the model error grows with the test's
        severity (a hidden backlash or compliance shows up at high accelerations).
    alternatives : list of dict
        Other least-squares laws (from the refit's other starting points) that fit the
        samples equally well (likelihood ratio on the effective sample size, 95 %); the
        band holds their distance to the law (they extrapolate differently).
    weighted : dict or None
        The law refitted with every test weighted by the inverse of its residual variance
        (feasible weighted least squares, tests as the units of error level).  Where the
        tests fit alike it is the law; where a model error grows in some tests (a hidden
        backlash in the hard-driven ones) the two part, and the band holds their distance:
        an error a test repeats in every cycle biases the law, which no spread-based
        covariance sees.  The band is at least that distance (within the statistical
        band the two differ by noise alone).
    test_n_samples, test_n_effective : list of float
        Per test: the friction samples used and their effective number n / (1 + 2 Σ w_l ρ_l)
        (the residuals' autocorrelation, as in ``n_effective``) — how many independent
        samples a test of that length carries (empty in files of earlier versions).
    """

    parameters: dict[str, float]
    free: list[str]
    covariance: np.ndarray
    covariance_iid: np.ndarray
    lead_m_per_rad: float
    n_samples: int
    n_effective: float
    bandwidths: list[int] = field(default_factory=list)
    residual_rms_N: float = math.nan
    velocity_range_m_per_s: tuple[float, float] = (math.nan, math.nan)
    covariance_cluster: np.ndarray | None = None
    n_tests: int = 1
    test_residual_rms_N: list[float] = field(default_factory=list)
    test_peak_acceleration_m_per_s2: list[float] = field(default_factory=list)
    alternatives: list[dict[str, float]] = field(default_factory=list)
    weighted: dict[str, float] | None = None
    test_n_samples: list[float] = field(default_factory=list)
    test_n_effective: list[float] = field(default_factory=list)

    def rod_N(self, v_m_per_s: Any) -> np.ndarray:
        """F_rod of the law at ``v_m_per_s``."""
        return np.asarray(rod_friction_N(np.asarray(v_m_per_s, dtype=float),
                                         [self.parameters[n] for n in FRICTION_NAMES],
                                         self.lead_m_per_rad), dtype=float)

    def std_N(self, v_m_per_s: Any, kind: str = "hac") -> np.ndarray:
        """Standard error of F_rod(v): ``"hac"`` (Newey–West), ``"cluster"`` (tests as
        clusters; NaN with fewer than four tests) or ``"iid"``."""
        v = np.atleast_1d(np.asarray(v_m_per_s, dtype=float))
        C = {"hac": self.covariance, "iid": self.covariance_iid,
             "cluster": self.covariance_cluster}[kind]
        if C is None:
            return np.full(v.shape, np.nan)
        G = rod_gradient(v, self.parameters, self.free, self.lead_m_per_rad)
        return np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", G, C, G), 0.0))

    def half_width_N(self, v_m_per_s: Any, level: float = 0.95) -> np.ndarray:
        """Half-width of the ``level`` band of F_rod(v): the larger of the Newey–West
        one (normal quantile) and the cluster-robust one (Student t, tests − 1 degrees
        of freedom), so neither the autocorrelation within a test nor an error shared
        by the cycles of a test makes it too narrow; plus the largest distance of an
        equally good alternative law (:attr:`alternatives`); at least the distance of the
        weighted law (:meth:`model_error_N`), which differs from the law by noise alone
        within that band and by a model error beyond it."""
        from scipy import stats
        hw = stats.norm.ppf(0.5 + level / 2) * self.std_N(v_m_per_s, "hac")
        if self.covariance_cluster is not None:
            tq = stats.t.ppf(0.5 + level / 2, max(self.n_tests - 1, 1))
            hw = np.fmax(hw, tq * self.std_N(v_m_per_s, "cluster"))
        if self.alternatives:
            v = np.atleast_1d(np.asarray(v_m_per_s, dtype=float))
            f = self.rod_N(v)
            hw = hw + np.max([np.abs(np.asarray(rod_friction_N(
                v, [a[n] for n in FRICTION_NAMES], self.lead_m_per_rad)) - f)
                for a in self.alternatives], axis=0)
        # the weighted law differs from the law by noise alone within the statistical
        # band; where it lies beyond, the band reaches it
        return np.fmax(hw, self.model_error_N(v_m_per_s))

    def model_error_N(self, v_m_per_s: Any) -> np.ndarray:
        """|F_rod(v; weighted) − F_rod(v; law)| (:attr:`weighted`; zero without it): how
        far the law moves when the tests are weighted by how well they fit."""
        v = np.atleast_1d(np.asarray(v_m_per_s, dtype=float))
        if not self.weighted:
            return np.zeros(v.shape)
        return np.abs(np.asarray(rod_friction_N(
            v, [self.weighted[n] for n in FRICTION_NAMES], self.lead_m_per_rad))
            - self.rod_N(v))

    def band_N(self, v_m_per_s: Any, level: float = 0.95) -> tuple[np.ndarray, np.ndarray]:
        """Lower and upper ``level`` band of F_rod(v) (:meth:`half_width_N`)."""
        f, h = self.rod_N(v_m_per_s), self.half_width_N(v_m_per_s, level)
        return f - h, f + h

    def summary(self) -> str:
        """The law's fit in a few lines: samples, effective samples, residual, the free
        parameters with their Newey–West standard errors."""
        sd = np.sqrt(np.maximum(np.diag(np.asarray(self.covariance, dtype=float)), 0.0))
        lines = [f"rod-friction law on {self.n_samples} samples of {self.n_tests} tests "
                 f"(effective {self.n_effective:.0f}), residual rms {self.residual_rms_N:.3g} N"]
        lines += [f"  {n} = {self.parameters[n]:.6g} ± {s:.2g}" for n, s in zip(self.free, sd)]
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """The law, its covariances and statistics as standard-JSON types
        (identification.json ``friction_envelope.extrapolation_band.law``)."""
        return {"method": "sandwich covariance of the rod-friction regression on the "
                          "friction samples F_e - F_0 at the measured stroke velocity: the "
                          "larger of Newey-West (Bartlett kernel, Andrews AR(1) bandwidth per "
                          "test) and cluster-robust (tests as clusters, Student t)",
                "n_tests": self.n_tests,
                "n_samples": self.n_samples, "n_effective": self.n_effective,
                "bandwidths": self.bandwidths, "residual_rms_N": self.residual_rms_N,
                "free": self.free, "parameters": dict(self.parameters),
                "lead_m_per_rad": self.lead_m_per_rad,
                "velocity_range_m_per_s": list(self.velocity_range_m_per_s),
                "test_residual_rms_N": [float(x) for x in self.test_residual_rms_N],
                "test_peak_acceleration_m_per_s2": [
                    None if not math.isfinite(x) else float(x)
                    for x in self.test_peak_acceleration_m_per_s2],
                "alternatives": [dict(a) for a in self.alternatives],
                "weighted": None if self.weighted is None else dict(self.weighted),
                "test_n_samples": [float(x) for x in self.test_n_samples],
                "test_n_effective": [float(x) for x in self.test_n_effective],
                "covariance": np.asarray(self.covariance).tolist(),
                "covariance_iid": np.asarray(self.covariance_iid).tolist(),
                "covariance_cluster": (None if self.covariance_cluster is None else
                                       np.asarray(self.covariance_cluster).tolist())}

    def to_json(self) -> str:
        """:meth:`to_dict` as standard JSON text (NaN written as null)."""
        from ..utils.io import json_safe
        return json.dumps(json_safe(self.to_dict()), indent=1, allow_nan=False)

    @classmethod
    def from_json(cls, text: str, where: str = "rod-friction law") -> "RodLawFit":
        """Reload a law written by :meth:`to_json` (validated as :meth:`from_dict`)."""
        from ..utils.limits import parse_json
        return cls.from_dict(parse_json(text, where, ParameterError), where)

    @classmethod
    def from_dict(cls, d: Mapping[str, Any], where: str = "rod-friction law") -> "RodLawFit":
        """Inverse of :meth:`to_dict` (identification.json ``extrapolation_band.law``;
        the list of free names is read from ``free``, or ``varied`` in files written by
        earlier versions).  Validated as received data
        (:func:`~ehsa_opt.datasets.identification_file.check_law`: physical parameters,
        known names, positive semi-definite covariances, effective samples >= 1);
        :class:`~ehsa_opt.physics.params.ParameterError` names ``where`` and the key."""
        from ..datasets.identification_file import check_law
        check_law(d, where)
        cl = d.get("covariance_cluster")
        free = d["free"] if "free" in d else d["varied"]

        def num(x: Any) -> float:  # null is how standard JSON writes NaN
            return math.nan if x is None else float(x)
        return cls({k: float(v) for k, v in d["parameters"].items()}, list(free),
                   np.asarray(d["covariance"], dtype=float),
                   np.asarray(d["covariance_iid"], dtype=float), float(d["lead_m_per_rad"]),
                   int(d["n_samples"]), float(d["n_effective"]), list(d.get("bandwidths", [])),
                   num(d.get("residual_rms_N")),
                   tuple(num(x) for x in d.get("velocity_range_m_per_s") or (None, None)),
                   None if cl is None else np.asarray(cl, dtype=float),
                   int(d.get("n_tests", 1)),
                   [num(x) for x in d.get("test_residual_rms_N", [])],
                   [num(x) for x in d.get("test_peak_acceleration_m_per_s2", [])],
                   [{k: float(v) for k, v in a.items()} for a in d.get("alternatives", [])],
                   None if not d.get("weighted") else
                   {k: float(v) for k, v in d["weighted"].items()},
                   [num(x) for x in d.get("test_n_samples", [])],
                   [num(x) for x in d.get("test_n_effective", [])])


def _free_names(params: Mapping[str, float], has_generator: bool) -> list[str]:
    names = list(FRICTION_NAMES if has_generator else FRICTION_NAMES[:4])
    return [n for n in names if n in params]


def rod_law_fit(samples: FrictionSamples, parameters: Mapping[str, float],
                lead_m_per_rad: float, *, has_generator: bool = True,
                free: Sequence[str] | None = None, refit: bool = False,
                rcond: float = 1e-6, max_samples_per_test: int = 4000) -> RodLawFit:
    """The law ``parameters`` (or its least-squares refit on the samples when ``refit``)
    with its HAC covariance on ``samples``.

    ``refit`` fits the free parameters by bounded least squares
    (``scipy.optimize.least_squares``) from ``parameters`` — the estimator whose sandwich
    the covariance is; without it the covariance is evaluated at the given law (the
    identification's minimax fit, close to the least-squares one on noise-dominated data).
    """
    from scipy import optimize
    lead = float(lead_m_per_rad)
    weighted = None
    p0 = {n: float(parameters.get(n, 0.0) or 0.0) for n in FRICTION_NAMES}
    if p0["nut_breakaway_velocity_m_per_s"] <= 0:
        p0["nut_breakaway_velocity_m_per_s"] = 0.01
    if p0["bearing_breakaway_velocity_rad_per_s"] <= 0:
        p0["bearing_breakaway_velocity_rad_per_s"] = 1.0
    names = list(free) if free is not None else _free_names(p0, has_generator)
    vs, ys = [], []
    for v, y in zip(samples.velocity_m_per_s, samples.friction_N):
        step = max(1, int(math.ceil(v.size / max_samples_per_test)))
        vs.append(v[::step])
        ys.append(y[::step])
    if refit:
        # q: nut/bearing excess over Coulomb (breakaway >= Coulomb by construction)
        def unpack(q: np.ndarray) -> dict[str, float]:
            p = dict(p0)
            for j, n in enumerate(names):
                p[n] = q[j] * _SCALE[n]
            return p

        def to_law(p: Mapping[str, float]) -> list[float]:
            law = [p[n] for n in FRICTION_NAMES]
            law[0] = max(law[0], law[1])
            law[4] = max(law[4], law[5])
            return law

        vcat, ycat = np.concatenate(vs), np.concatenate(ys)

        def resid(q: np.ndarray) -> np.ndarray:
            return np.asarray(rod_friction_N(vcat, to_law(unpack(q)), lead)) - ycat
        lo = np.array([(1e-4 if "velocity" in n else 0.0) / _SCALE[n] for n in names])
        fits = []
        for start in _refit_starts(p0, lead, names):
            q0 = np.clip(np.array([start[n] / _SCALE[n] for n in names]), lo, np.inf)
            res = optimize.least_squares(resid, q0, bounds=(lo, np.inf), x_scale="jac")
            fits.append((2.0 * float(res.cost), to_law(unpack(res.x))))
        fits.sort(key=lambda f: f[0])
        p0 = dict(zip(FRICTION_NAMES, fits[0][1]))
        # feasible weighted least squares: every test weighted by the inverse of its
        # residual variance at the law (floored at a hundredth of the median variance, so
        # one test that happens to fit exactly does not own the fit)
        if len(vs) > 1:
            law0 = [p0[n] for n in FRICTION_NAMES]
            var = np.array([float(np.mean((np.asarray(rod_friction_N(v, law0, lead)) - y) ** 2))
                            for v, y in zip(vs, ys)])
            var = np.maximum(var, 1e-2 * float(np.median(var)) + 1e-12)
            wcat = np.concatenate([np.full(v.size, 1.0 / math.sqrt(g)) for v, g in zip(vs, var)])
            q0 = np.clip(np.array([p0[n] / _SCALE[n] for n in names]), lo, np.inf)
            res = optimize.least_squares(lambda q: resid(q) * wcat, q0, bounds=(lo, np.inf),
                                         x_scale="jac")
            weighted = dict(zip(FRICTION_NAMES, to_law(unpack(res.x))))
    Js, es = [], []
    for v, y in zip(vs, ys):
        Js.append(rod_gradient(v, p0, names, lead))
        es.append(y - np.asarray(rod_friction_N(v, [p0[n] for n in FRICTION_NAMES], lead)))
    cov, cov_iid, Ls, neff = hac_covariance(Js, es, rcond=rcond)
    cov_cl = cluster_covariance(Js, es, rcond=rcond) if len(Js) >= _MIN_CLUSTERS else None
    ecat = np.concatenate(es)
    alternatives = []
    if refit and len(fits) > 1:
        # equally good laws: a likelihood-ratio threshold on the effective sample size
        # (chi-square 1 dof, 95 %): ΔSSE <= 3.84 σ² n/n_eff
        sse0 = fits[0][0]
        tau = ecat.size / max(float(sum(neff)), 1.0)
        tol = 3.84 * sse0 / max(ecat.size, 1) * tau
        alternatives = [dict(zip(FRICTION_NAMES, law)) for sse, law in fits[1:]
                        if sse - sse0 <= tol]
    peaks = samples.peak_velocity_m_per_s()
    return RodLawFit(p0, names, cov, cov_iid, lead, int(ecat.size), float(sum(neff)), Ls,
                     float(np.sqrt(np.mean(ecat ** 2))),
                     (float(peaks.min()), float(peaks.max())), cov_cl, len(Js),
                     [float(np.sqrt(np.mean(e ** 2))) for e in es],
                     [float(x) for x in samples.peak_acceleration_m_per_s2()], alternatives,
                     weighted, [float(e.size) for e in es], [float(x) for x in neff])


def _refit_starts(p: Mapping[str, float], lead: float, names: Sequence[str]
                  ) -> list[dict[str, float]]:
    """Starting points of the least-squares refit: the given law and the same rod friction
    with its non-identifiable parts moved (the viscous slope all at the nut or all at the
    bearing, the bearing's Coulomb level at the nut) and with both Stribeck velocities
    five times larger and smaller — the rod friction's least squares has separate local
    minima along these directions, which extrapolate differently."""
    out = [dict(p)]
    if "bearing_viscous_Nms_per_rad" in names:
        r2 = lead * lead
        nut = dict(p, nut_viscous_Ns_per_m=p["nut_viscous_Ns_per_m"]
                   + p["bearing_viscous_Nms_per_rad"] / r2, bearing_viscous_Nms_per_rad=0.0)
        brg = dict(p, nut_viscous_Ns_per_m=0.0, bearing_viscous_Nms_per_rad=(
            p["bearing_viscous_Nms_per_rad"] + p["nut_viscous_Ns_per_m"] * r2))
        col = dict(p, nut_coulomb_N=p["nut_coulomb_N"] + p["bearing_coulomb_Nm"] / lead,
                   nut_breakaway_N=p["nut_breakaway_N"] + p["bearing_breakaway_Nm"] / lead,
                   bearing_coulomb_Nm=0.0, bearing_breakaway_Nm=0.0)
        out += [nut, brg, col]
    for k in (5.0, 0.2):
        out.append({n: (v * k if "breakaway_velocity" in n else v) for n, v in p.items()})
    return out
