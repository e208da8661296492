"""Validity of quarter-car results: where a model's answer must not be used.

A result is *invalid* when the model that produced it is outside its domain:

``tyre_lift``
    the dynamic tyre force exceeds the static load (the tyre leaves the ground and the
    linear tyre spring is wrong) for more than :data:`TYRE_LIFT_FRACTION_LIMIT` of the
    time: per sample in the time domain (``tyre_lift_fraction``), as the Gaussian share
    Q(1/η_rh) where only the road holding η_rh (rms dynamic load over static) is known.
``stroke_limit``
    the stroke |x2 − x1| exceeds the vehicle's ``stroke_limit_m`` (the suspension would
    hit its bump stops, which the model does not have) for more than
    :data:`EXCEEDANCE_FRACTION_LIMIT` of the time (``stroke_beyond_limit_fraction``);
    a frequency-response amplitude or a peak without per-sample data is checked on
    the value itself, frequency-path results (no peak) on
    :data:`GAUSSIAN_PEAK_FACTOR` × their rms stroke.
``screw_speed``, ``voltage``, ``current``
    the screw speed, the generator's terminal voltage or its current beyond the
    hardware's :class:`SampleLimits` for more than :data:`EXCEEDANCE_FRACTION_LIMIT` of
    the time (``*_beyond_limit_fraction``; time domain only, limits given by the caller).
``fast_path_region``
    a friction-aware fast-path result whose design lies outside the region where the
    fast path was validated against the time domain (given by the caller as bounds).
``fast_path_indicator``
    a fast-path result whose own indicator (the sticking correction) is beyond
    :data:`FAST_PATH_MAX_CORRECTION`.

Checks live in :data:`VALIDITY_CHECKS`, a registry other checks join with
:func:`register_check` (each maps the metrics of a batch and the context to one
message or ``None`` per design).  :func:`check_validity` runs every check whose
inputs are present and returns a :class:`Validity`, which a report puts *in the table
itself* (:meth:`Validity.cell`) and uses to keep invalid rows out of its conclusion
sentences (:meth:`Validity.valid`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np

__all__ = ["GAUSSIAN_PEAK_FACTOR", "FAST_PATH_MAX_CORRECTION", "FAST_PATH_REGION",
           "TYRE_LIFT_FRACTION_LIMIT", "EXCEEDANCE_FRACTION_LIMIT", "SampleLimits",
           "PROTOTYPE_SAMPLE_LIMITS", "HARDWARE_CODES", "study_sample_limits",
           "exceedance_fractions",
           "ValidityFlag", "Validity", "VALIDITY_CHECKS",
           "register_check", "check_validity"]

#: Largest sticking correction c_gauss/c_f − 1 of the friction-aware fast path inside its
#: validated region: on the validation set (19 designs × 4 friction levels × 12 roads)
#: every metric is within 2.6 % of the time domain below 2 %, and the pairs above it carry
#: the largest errors (validation/friction_fast_path.py, also its ``--random`` mode).
FAST_PATH_MAX_CORRECTION = 0.02

#: Validated region of the friction-aware fast path over the whole design box
#: (``validation/friction_fast_path.py --random 500``: 500 random designs × one friction
#: level ×0.5–×4 × 8 held-out roads): with the design's electrical damping
#: c_e = K_t K_e/(r² (R_e + R_i)) ≥ 100 N s/m and friction up to ×2 the data's every pair
#: is within 5 % on all four metrics; below 30 N s/m errors reach 82 % (lightly damped
#: designs that stick).  Checked as ``fast_path_region`` on ``electrical_damping_Ns_per_m``.
FAST_PATH_REGION: dict[str, tuple[float, float]] = {
    "electrical_damping_Ns_per_m": (100.0, float("inf"))}

#: Peak / rms of a Gaussian response used where only the rms is known: 3.5 σ is
#: exceeded 0.05 % of the time (the 2000 m class C records of the prototype show
#: peak/rms 3.2–3.7 in the time domain).
GAUSSIAN_PEAK_FACTOR = 3.5

#: Largest share of the time the tyre may lift (dynamic load above the static one) in a
#: valid result: Q(3) = 0.135 %, the share a Gaussian wheel load lifts under the
#: road-holding criterion of vehicle dynamics, rms dynamic load ≤ 1/3 of the static load
#: (3 σ; Mitschke & Wallentowitz, *Dynamik der Kraftfahrzeuge*).
TYRE_LIFT_FRACTION_LIMIT = 0.5 * math.erfc(3.0 / math.sqrt(2.0))

#: Largest share of the time a hardware limit (stroke, screw speed, voltage, current) may
#: be exceeded in a valid result: 4.65e-4, the share a Gaussian response spends beyond
#: ±:data:`GAUSSIAN_PEAK_FACTOR` σ, the peak the product checks where only the rms is
#: known (so a time-domain row and a frequency-path row are held to the same standard).
EXCEEDANCE_FRACTION_LIMIT = math.erfc(GAUSSIAN_PEAK_FACTOR / math.sqrt(2.0))


@dataclass(frozen=True)
class SampleLimits:
    """Per-sample limits of the harvester's hardware (None: not checked).

    Attributes
    ----------
    screw_speed_rpm : float or None
        Largest screw (and rotor) speed, rpm.
    voltage_V : float or None
        Largest generator terminal voltage |R_e i|, V.
    current_A : float or None
        Largest generator current |i|, A (a peak; the thermal limit is an rms).
    source : str
        Where the values come from.
    """

    screw_speed_rpm: float | None = None
    voltage_V: float | None = None
    current_A: float | None = None
    source: str = ""

    def __post_init__(self) -> None:
        for name in ("screw_speed_rpm", "voltage_V", "current_A"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0.0):
                raise ValueError(f"SampleLimits: {name} = {v!r} must be a positive number "
                                 "or None (not checked)")


#: Limits the paper's prototype harvester is held to in the quarter-car studies (its own
#: ratings are not in the paper; both values are assumptions, stated where used):
#: screw speed 6250 rpm = a DN limit of 100 000 mm·rpm (standard rolled ball screws) on
#: a 16 mm screw (the usual diameter for a 5 mm lead); terminal voltage 48 V = the
#: nominal voltage of the shipped catalogue's motor of this power class (maxon 353297,
#: k_n 77.8 rpm/V against the prototype's 69.7).
PROTOTYPE_SAMPLE_LIMITS = SampleLimits(
    6250.0, 48.0, None, "assumed: screw DN 100 000 mm rpm on a 16 mm screw; generator "
    "voltage 48 V, the nominal voltage of a motor of this class (maxon 353297)")

#: Speed constant of the motor the voltage limit is taken from (maxon 353297), rpm/V.
_REFERENCE_SPEED_CONSTANT_RPM_PER_V = 77.8

#: Codes of the hardware limits: a row beyond them is computed correctly by the model for
#: a damper that could run there, but that damper is not realisable as specified.
HARDWARE_CODES = frozenset({"screw_speed", "voltage", "current"})


def study_sample_limits(voltage_constant_Vs_per_rad: float) -> SampleLimits:
    """:data:`PROTOTYPE_SAMPLE_LIMITS` for a winding of voltage constant K_e: the same
    screw speed, and the voltage of the same frame rewound for the same top speed,
    48 V × K_e / K_e,ref (K_e,ref of maxon 353297, 77.8 rpm/V)."""
    ke_ref = 60.0 / (2.0 * math.pi * _REFERENCE_SPEED_CONSTANT_RPM_PER_V)
    lim = PROTOTYPE_SAMPLE_LIMITS
    return SampleLimits(lim.screw_speed_rpm,
                        float(lim.voltage_V * voltage_constant_Vs_per_rad / ke_ref), None,
                        lim.source + ", rewound for this winding at the same top speed")


def exceedance_fractions(stroke_m: np.ndarray, tyre_deflection_m: np.ndarray,
                         stroke_velocity_m_s: np.ndarray, voltage_V: np.ndarray,
                         current_A: np.ndarray, *, static_deflection_m: float,
                         stroke_limit_m: float, lead_m_per_rad: np.ndarray,
                         limits: SampleLimits | None = None) -> dict[str, np.ndarray]:
    """Share of the samples beyond each per-sample limit, per design.

    Parameters
    ----------
    stroke_m, tyre_deflection_m, stroke_velocity_m_s, voltage_V, current_A : ndarray (B, N)
        Stroke x2 − x1, tyre extension x1 − x0 (positive: the wheel above the road),
        stroke velocity, terminal voltage R_e i and current over the window.
    static_deflection_m : float
        Static tyre compression (m_total g / k1): the tyre lifts where the extension
        exceeds it.
    stroke_limit_m : float
    lead_m_per_rad : ndarray (B,)
        Screw lead r (m/rad): the screw turns at |v| / r.
    limits : SampleLimits, optional

    Returns
    -------
    dict of ndarray (B,)
        ``tyre_lift_fraction``, ``stroke_beyond_limit_fraction``, ``peak_screw_speed_rpm``
        and, for each limit given, ``screw_speed_beyond_limit_fraction``,
        ``voltage_beyond_limit_fraction``, ``current_beyond_limit_fraction`` (NaN for a
        limit not given).
    """
    lim = limits or SampleLimits()
    rpm = np.abs(stroke_velocity_m_s) / np.asarray(lead_m_per_rad, float)[:, None] \
        * 60.0 / (2.0 * math.pi)
    out = {"tyre_lift_fraction": np.mean(tyre_deflection_m > static_deflection_m, axis=1),
           "stroke_beyond_limit_fraction": np.mean(np.abs(stroke_m) > stroke_limit_m, axis=1),
           "peak_screw_speed_rpm": np.max(rpm, axis=1)}
    nan = np.full(rpm.shape[0], np.nan)
    for key, sig, limit in (("screw_speed", rpm, lim.screw_speed_rpm),
                            ("voltage", voltage_V, lim.voltage_V),
                            ("current", current_A, lim.current_A)):
        out[f"{key}_beyond_limit_fraction"] = (
            nan if limit is None else np.mean(np.abs(sig) > limit, axis=1))
    return out


@dataclass(frozen=True)
class ValidityFlag:
    """One reason a result is invalid: a short ``code`` and a sentence with the numbers."""

    code: str
    message: str


Check = Callable[[Mapping[str, np.ndarray], Mapping[str, Any]], Sequence[str | None]]

#: Registered checks: ``code -> check(metrics, context) -> per-design message or None``.
#: A check returns None for every design when its inputs are absent.
VALIDITY_CHECKS: dict[str, Check] = {}


def register_check(code: str, check: Check) -> None:
    """Add a validity check (replacing one of the same code)."""
    if not code or not code.replace("_", "").isalnum():
        raise ValueError(f"register_check: code {code!r} must be a short identifier")
    VALIDITY_CHECKS[code] = check


@dataclass(frozen=True)
class Validity:
    """Validity flags of a batch of results, one tuple of flags per result."""

    flags: tuple[tuple[ValidityFlag, ...], ...]

    @property
    def valid(self) -> np.ndarray:
        """True where a result has no flag (bool array, one per result)."""
        return np.array([not f for f in self.flags], dtype=bool)

    @property
    def all_valid(self) -> bool:
        return bool(np.all(self.valid))

    @property
    def model_valid(self) -> np.ndarray:
        """True where the *model* is inside its domain (no flag but hardware limits):
        its numbers hold for a damper that could run there."""
        return np.array([all(f.code in HARDWARE_CODES for f in fl) for fl in self.flags],
                        dtype=bool)

    def cell(self, k: int) -> str:
        """Table cell of result ``k``: ``valid``, or the reasons in bold — INVALID when
        the model is outside its domain, NOT REALISABLE when only hardware limits are
        exceeded."""
        if not self.flags[k]:
            return "valid"
        head = ("NOT REALISABLE" if all(f.code in HARDWARE_CODES for f in self.flags[k])
                else "INVALID")
        return f"**{head}: " + "; ".join(f.message for f in self.flags[k]) + "**"

    def codes(self, k: int) -> list[str]:
        return [f.code for f in self.flags[k]]

    def join(self, other: "Validity") -> "Validity":
        """Per-result union with the flags of ``other`` (same number of results)."""
        if len(other.flags) != len(self.flags):
            raise ValueError(f"Validity.join: {len(self.flags)} results vs "
                             f"{len(other.flags)}")
        return Validity(tuple(a + tuple(f for f in b if f not in a)
                              for a, b in zip(self.flags, other.flags)))

    def as_list(self) -> list[list[dict[str, str]]]:
        """Plain data (for JSON results)."""
        return [[{"code": f.code, "message": f.message} for f in fl] for fl in self.flags]


def _percent(x: float) -> str:
    return f"{100 * x:.2g} %"


def _tyre_lift(metrics: Mapping[str, np.ndarray], ctx: Mapping[str, Any]) -> list[str | None]:
    lim = TYRE_LIFT_FRACTION_LIMIT
    rh = np.atleast_1d(np.asarray(metrics["road_holding"], dtype=float))
    if "tyre_lift_fraction" in metrics:
        frac = np.atleast_1d(np.asarray(metrics["tyre_lift_fraction"], float))
        how = ["of the time"] * frac.size
    else:  # Gaussian dynamic load of rms η_rh × static: lifts Q(1/η_rh) of the time
        frac = np.array([0.5 * math.erfc(1.0 / (x * math.sqrt(2.0))) if x > 0 else 0.0
                         for x in rh])
        how = [f"of the time if Gaussian (road holding {x:.2f})" for x in rh]
    return [f"tyre leaves the ground {_percent(f)} {h} (limit {_percent(lim)}; linear "
            "tyre invalid)" if f > lim else None for f, h in zip(frac, how)]


def _hardware(metrics: Mapping[str, np.ndarray], ctx: Mapping[str, Any],
              key: str, what: str) -> list[str | None]:
    name = f"{key}_beyond_limit_fraction"
    if name not in metrics:
        return [None] * _n(metrics)
    frac = np.atleast_1d(np.asarray(metrics[name], float))
    lim = ctx.get("sample_limits")
    limit = getattr(lim, {"screw_speed": "screw_speed_rpm", "voltage": "voltage_V",
                          "current": "current_A"}[key], None) if lim is not None else None
    unit = {"screw_speed": "rpm", "voltage": "V", "current": "A"}[key]
    beyond = f" {limit:.4g} {unit}" if limit is not None else " its limit"
    return [f"{what} beyond{beyond} {_percent(f)} of the time (limit "
            f"{_percent(EXCEEDANCE_FRACTION_LIMIT)})"
            if np.isfinite(f) and f > EXCEEDANCE_FRACTION_LIMIT else None for f in frac]


def _stroke(metrics: Mapping[str, np.ndarray], ctx: Mapping[str, Any]) -> list[str | None]:
    limit = ctx.get("stroke_limit_m")
    if "stroke_beyond_limit_fraction" in metrics and limit is not None:
        frac = np.atleast_1d(np.asarray(metrics["stroke_beyond_limit_fraction"], float))
        peak = np.atleast_1d(np.asarray(metrics.get("peak_stroke_m", frac * np.nan), float))
        return [f"stroke beyond the {1e3 * limit:.0f} mm limit {_percent(f)} of the time "
                f"(peak {1e3 * p:.0f} mm; limit {_percent(EXCEEDANCE_FRACTION_LIMIT)})"
                if f > EXCEEDANCE_FRACTION_LIMIT else None for f, p in zip(frac, peak)]
    if "peak_stroke_m" in metrics:
        peak, how = np.atleast_1d(np.asarray(metrics["peak_stroke_m"], float)), "peak"
    elif "stroke_rms_m" in metrics:
        peak = GAUSSIAN_PEAK_FACTOR * np.atleast_1d(np.asarray(metrics["stroke_rms_m"], float))
        how = f"{GAUSSIAN_PEAK_FACTOR:g} x rms"
    else:
        return [None] * _n(metrics)
    if limit is None:
        return [None] * peak.size
    return [f"stroke {1e3 * v:.0f} mm ({how}) beyond the {1e3 * limit:.0f} mm limit"
            if v > limit else None for v in peak]


def _fast_path_region(metrics: Mapping[str, np.ndarray],
                      ctx: Mapping[str, Any]) -> list[str | None]:
    region = ctx.get("fast_path_region")
    design = ctx.get("design")
    n = _n(metrics)
    if not region or design is None:
        return [None] * n
    out: list[str | None] = [None] * n
    for name, (lo, hi) in region.items():
        if name not in design:
            continue
        vals = np.broadcast_to(np.asarray(design[name], dtype=float), (n,))
        for k, v in enumerate(vals):
            if not lo <= v <= hi:
                msg = f"fast path not validated at {name} = {v:.4g} (validated {lo:g}-{hi:g})"
                out[k] = msg if out[k] is None else out[k] + "; " + msg
    return out


def _fast_path_indicator(metrics: Mapping[str, np.ndarray],
                         ctx: Mapping[str, Any]) -> list[str | None]:
    """The fast path's own indicator: the sticking correction c_gauss/c_f − 1 of
    :func:`~ehsa_opt.vehicle.fast_path.friction_metrics` beyond
    :data:`FAST_PATH_MAX_CORRECTION` (the strut sticks for long stretches, the
    Gaussian closure is no longer accurate)."""
    n = _n(metrics)
    if "friction_damping_gaussian_Ns_per_m" not in metrics:
        return [None] * n
    cg = np.atleast_1d(np.asarray(metrics["friction_damping_gaussian_Ns_per_m"], float))
    cf = np.atleast_1d(np.asarray(metrics["friction_damping_Ns_per_m"], float))
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = np.where(cf > 0.0, cg / cf - 1.0, 0.0)
    return [f"fast path outside its validated region (sticking correction {100 * c:.1f} % "
            f"> {100 * FAST_PATH_MAX_CORRECTION:g} %)" if c > FAST_PATH_MAX_CORRECTION else None
            for c in corr]


def _n(metrics: Mapping[str, np.ndarray]) -> int:
    return int(np.atleast_1d(np.asarray(next(iter(metrics.values())))).size)


register_check("tyre_lift", _tyre_lift)
register_check("stroke_limit", _stroke)
register_check("fast_path_region", _fast_path_region)
register_check("fast_path_indicator", _fast_path_indicator)
register_check("screw_speed", lambda m, c: _hardware(m, c, "screw_speed", "screw speed"))
register_check("voltage", lambda m, c: _hardware(m, c, "voltage", "generator voltage"))
register_check("current", lambda m, c: _hardware(m, c, "current", "generator current"))


def check_validity(metrics: Mapping[str, Any], *, stroke_limit_m: float | None = None,
                   fast_path_region: Mapping[str, tuple[float, float]] | None = None,
                   design: Mapping[str, Any] | None = None,
                   sample_limits: SampleLimits | None = None, **context: Any) -> Validity:
    """Run every registered check on a batch of results.

    Parameters
    ----------
    metrics : mapping of array_like
        Per-result metrics (time-domain :attr:`QuarterCarSimulation.metrics` or the
        frequency path's dict); ``road_holding`` is required.
    stroke_limit_m : float, optional
        The vehicle's stroke limit (``VehicleParams.stroke_limit_m``); None: not checked.
    fast_path_region : mapping name -> (lo, hi), optional
        Bounds of the fast path's validated region, checked on ``design`` (same names).
    design : mapping of array_like, optional
        The results' design variables.
    sample_limits : SampleLimits, optional
        The hardware limits the ``*_beyond_limit_fraction`` metrics were measured against
        (named in the messages).
    **context
        Passed to registered checks (e.g. a friction check's identified velocity range).
    """
    m = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in metrics.items()
         if np.asarray(v).dtype.kind in "fiub"}
    if "road_holding" not in m:
        raise ValueError("check_validity: metrics need 'road_holding'")
    n = m["road_holding"].size
    ctx = dict(context, stroke_limit_m=stroke_limit_m, fast_path_region=fast_path_region,
               design=design, sample_limits=sample_limits)
    flags: list[list[ValidityFlag]] = [[] for _ in range(n)]
    for code, check in VALIDITY_CHECKS.items():
        for k, msg in enumerate(check(m, ctx)):
            if msg:
                flags[k].append(ValidityFlag(code, msg))
    return Validity(tuple(tuple(f) for f in flags))
