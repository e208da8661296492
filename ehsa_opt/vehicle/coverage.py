"""Where a vehicle result leaves the friction's identified range.

The friction sets are identified on a bench that reaches some peak stroke velocity (the
campaign's range, ``velocity_range`` of ``identification.json``); above it the friction is
an extrapolation of the fitted law.  A vehicle result states how much of it rests on that
extrapolation: the fraction of **time** the stroke velocity spends above the identified
range, and the fraction of the **friction's dissipated energy** E[F_f(v) v] that is
dissipated there — and warns when either exceeds :data:`OUT_OF_RANGE_LIMIT`.

Two paths:

* time domain: from the stroke-velocity series (exact for the simulated record);
* the fast statistical-linearisation path: the stroke velocity is Gaussian with the
  design's σ_v, so the time fraction is erfc(v_max / (σ_v √2)) and the energy fraction a
  one-dimensional Gauss–Legendre quadrature of F_f(v) v against the normal density.
"""

from __future__ import annotations

import math
from typing import Any, Mapping

import numpy as np
from scipy import special

from ..datasets.friction_source import (  # noqa: F401  (re-exported for the CLI)
    RANGE_SOURCE_EMBEDDED,
    embedded_range_m_per_s,
    identified_range_for,
)
from ..physics.friction import rod_friction_N

__all__ = ["OUT_OF_RANGE_LIMIT", "embedded_range_m_per_s", "gaussian_coverage",
           "series_coverage", "coverage_warning", "coverage_text", "RANGE_SOURCE_EMBEDDED",
           "design_coverage", "metrics_warning", "coverage_rows", "out_of_range_lines"]

#: Warn when more than this fraction of the time or of the friction's dissipated energy
#: falls at stroke velocities above the identified range.
OUT_OF_RANGE_LIMIT = 0.10

_GL_X, _GL_W = np.polynomial.legendre.leggauss(96)


def _rod_power(v: np.ndarray, friction: Any, lead: np.ndarray) -> np.ndarray:
    """F_f(v) v at the rod (W), ``friction`` a FrictionParams or an array (..., 8)."""
    if hasattr(friction, "as_array"):
        fr = np.asarray(friction.as_array(), dtype=float)
    else:
        fr = np.asarray(friction, dtype=float)
    p = [fr[..., k, None] for k in range(8)]
    return np.asarray(rod_friction_N(v, p, lead[..., None]), dtype=float) * v


def gaussian_coverage(sigma_v_m_per_s: Any, v_max_m_per_s: float, friction: Any = None,
                      lead_m_per_rad: Any = None) -> dict[str, np.ndarray]:
    """Out-of-range fractions of a Gaussian stroke velocity (the fast path).

    Parameters
    ----------
    sigma_v_m_per_s : array
        σ_v of each design.
    v_max_m_per_s : float
        The identified range's upper end.
    friction : FrictionParams or array (..., 8), optional
        Broadcast against ``sigma_v_m_per_s``; None: no energy fraction (NaN).
    lead_m_per_rad : array, optional
        Lead of each design (with ``friction``).

    Returns
    -------
    dict
        ``time_fraction`` = erfc(v_max / (σ √2)); ``energy_fraction`` of E[F_f(v) v].
    """
    s = np.atleast_1d(np.asarray(sigma_v_m_per_s, dtype=float))
    vmax = float(v_max_m_per_s)
    with np.errstate(divide="ignore", invalid="ignore"):
        time = special.erfc(vmax / (np.maximum(s, 1e-300) * math.sqrt(2.0)))
    energy = np.full(s.shape, np.nan)
    if friction is not None:
        lead = np.broadcast_to(np.asarray(lead_m_per_rad, dtype=float), s.shape)
        fr = friction if hasattr(friction, "as_array") else np.broadcast_to(
            np.asarray(friction, dtype=float), s.shape + (8,))
        # u = v / σ on [0, 10]: inside / outside split at u_c = v_max / σ, each on its
        # own Gauss-Legendre nodes (the integrand has a kink nowhere, but is steep)
        u_top = 10.0
        uc = np.clip(vmax / np.maximum(s, 1e-300), 0.0, u_top)

        def part(a: np.ndarray, b: np.ndarray) -> np.ndarray:
            half = 0.5 * (b - a)
            u = (a + b)[..., None] * 0.5 + half[..., None] * _GL_X
            v = u * s[..., None]
            phi = np.exp(-0.5 * u * u)
            return half * np.sum(_GL_W * _rod_power(v, fr, lead) * phi, axis=-1)
        inside = part(np.zeros_like(uc), uc)
        outside = part(uc, np.full_like(uc, u_top))
        total = inside + outside
        energy = np.where(total > 0, outside / np.maximum(total, 1e-300), 0.0)
    return {"time_fraction": time, "energy_fraction": energy}


def series_coverage(v_m_per_s: np.ndarray, v_max_m_per_s: float,
                    friction_power_W: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """Out-of-range fractions of stroke-velocity series (the time domain).

    ``v_m_per_s`` (designs × samples); ``friction_power_W`` the friction's dissipated
    power on the same samples (≥ 0).
    """
    v = np.atleast_2d(np.asarray(v_m_per_s, dtype=float))
    out = np.abs(v) > float(v_max_m_per_s)
    res = {"time_fraction": out.mean(axis=1), "energy_fraction": np.full(v.shape[0], np.nan)}
    if friction_power_W is not None:
        p = np.atleast_2d(np.asarray(friction_power_W, dtype=float))
        tot = p.sum(axis=1)
        res["energy_fraction"] = np.where(tot > 0, (p * out).sum(axis=1)
                                          / np.maximum(tot, 1e-300), 0.0)
    return res


def coverage_text(cov: Mapping[str, Any], v_max_m_per_s: float) -> str:
    """One line: the fractions above the identified range."""
    t = float(np.max(cov["time_fraction"]))
    e = np.asarray(cov.get("energy_fraction", np.nan), dtype=float)
    e_txt = "n/a (frictionless)" if np.all(np.isnan(e)) else f"{100 * float(np.nanmax(e)):.1f} %"
    return (f"stroke velocity above the friction's identified range (|v| > "
            f"{v_max_m_per_s:.3g} m/s): {100 * t:.1f} % of the time, {e_txt} of the "
            f"friction's dissipated energy")


def coverage_warning(cov: Mapping[str, Any], v_max_m_per_s: float,
                     limit: float = OUT_OF_RANGE_LIMIT) -> str | None:
    """A warning when a fraction exceeds ``limit`` (None otherwise; None without friction,
    whose energy fraction is NaN: nothing is extrapolated then)."""
    t = float(np.nanmax(np.asarray(cov["time_fraction"], dtype=float)))
    e = np.asarray(cov.get("energy_fraction", np.nan), dtype=float)
    if np.all(np.isnan(e)):
        return None
    e = float(np.nanmax(e))
    if max(t, e) <= limit:
        return None
    return (coverage_text(cov, v_max_m_per_s) + f" — above the {100 * limit:g} % limit: the "
            "friction there is an extrapolation of the fitted law (see the min/max sets' "
            "band; `ehsa-opt plan-tests` proposes bench tests that cover it)")


def design_coverage(vehicle: Any, road: Any, design: Mapping[str, Any], frictions: Any,
                    v_max_m_per_s: float, base: Any = None) -> dict[str, np.ndarray]:
    """Out-of-range fractions of designs on the fast path: σ_v of the friction-aware
    equivalent linearisation (:func:`ehsa_opt.vehicle.fast_path.friction_metrics`; the
    exact linear path when ``frictions`` is empty) and :func:`gaussian_coverage`.

    ``design`` as :func:`ehsa_opt.vehicle.frequency_path.linear_metrics`; ``frictions`` a
    sequence of FrictionParams (one row of fractions each) or empty.  Returns arrays
    (frictions or 1) × designs.
    """
    from .fast_path import friction_metrics
    from .frequency_path import design_arrays, linear_metrics
    d = design_arrays(design, base)
    lead = np.asarray(d["r_m_per_rad"], dtype=float)
    frs = list(frictions or [])
    times, energies = [], []
    if not frs:
        m = linear_metrics(vehicle, road, design, base=base)
        c = gaussian_coverage(m["stroke_velocity_rms_m_s"], v_max_m_per_s)
        return {"time_fraction": c["time_fraction"][None], "energy_fraction":
                c["energy_fraction"][None]}
    for fr in frs:
        m = friction_metrics(vehicle, road, design, fr, base=base)
        c = gaussian_coverage(m["stroke_velocity_rms_m_s"], v_max_m_per_s, fr, lead)
        times.append(c["time_fraction"])
        energies.append(c["energy_fraction"])
    return {"time_fraction": np.array(times), "energy_fraction": np.array(energies)}


def metrics_warning(m: dict, v_max_m_per_s: float, source: str = "") -> str | None:
    """:func:`coverage_warning` of a simulation's metrics (``out_of_range_*`` keys), with
    where the range comes from; records the range in ``m["identified_range_m_per_s"]``."""
    m["identified_range_m_per_s"] = float(v_max_m_per_s)
    e = m.get("out_of_range_friction_energy_fraction")
    w = coverage_warning({"time_fraction": m["out_of_range_time_fraction"],
                          "energy_fraction": np.nan if e is None else e}, v_max_m_per_s)
    return None if w is None else (w + (f" [{source}]" if source else ""))


def coverage_rows(m: Mapping[str, Any], v_max_m_per_s: float) -> list[tuple[str, Any]]:
    """(label, value in %) rows of a simulation's printed table."""
    e = m.get("out_of_range_friction_energy_fraction")
    return [(f"time with |v| > identified {v_max_m_per_s:.3g} m/s (%)",
             100.0 * m["out_of_range_time_fraction"]),
            ("friction energy at |v| > identified (%)", None if e is None else 100.0 * e)]


def out_of_range_lines(oor: Mapping[str, Any] | None) -> list[tuple[str, bool]]:
    """Printed lines (text, to stderr) of an optimisation's ``out_of_range`` block."""
    if not oor:
        return []
    e = [x for x in oor["energy_fraction"] if x is not None]
    out = [(f"stroke velocity above the identified {oor['identified_range_m_per_s']:.3g} m/s: "
            f"{100 * max(oor['time_fraction']):.1f} % of the time"
            + (f", {100 * max(e):.1f} % of the friction energy" if e else "")
            + f" (fast path; {oor['source']})", False)]
    if oor.get("warning"):
        out.append((f"warning: {oor['warning']}", True))
    return out
