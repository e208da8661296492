"""Validity of quarter-car results: where a model's answer must not be used.

A result is *invalid* when the model that produced it is outside its domain:

``tyre_lift``
    road holding η_rh > 1: the rms dynamic tyre force exceeds the static load, so the
    tyre leaves the ground for part of the time and the linear tyre spring is wrong.
``stroke_limit``
    the stroke |x2 − x1| exceeds the vehicle's ``stroke_limit_m``: the suspension would
    hit its bump stops, which the model does not have.  Time-domain results are checked
    on their peak stroke; frequency-path results (no peak) on
    :data:`GAUSSIAN_PEAK_FACTOR` × their rms stroke.
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

from dataclasses import dataclass
from typing import Any, Callable, Mapping, Sequence

import numpy as np

__all__ = ["GAUSSIAN_PEAK_FACTOR", "FAST_PATH_MAX_CORRECTION", "FAST_PATH_REGION",
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

    def cell(self, k: int) -> str:
        """Table cell of result ``k``: ``valid`` or the reasons in bold."""
        if not self.flags[k]:
            return "valid"
        return "**INVALID: " + "; ".join(f.message for f in self.flags[k]) + "**"

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


def _tyre_lift(metrics: Mapping[str, np.ndarray], ctx: Mapping[str, Any]) -> list[str | None]:
    rh = np.atleast_1d(np.asarray(metrics["road_holding"], dtype=float))
    return [f"tyre leaves the ground (road holding {v:.2f} > 1; linear tyre invalid)"
            if v > 1.0 else None for v in rh]


def _stroke(metrics: Mapping[str, np.ndarray], ctx: Mapping[str, Any]) -> list[str | None]:
    limit = ctx.get("stroke_limit_m")
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


def check_validity(metrics: Mapping[str, Any], *, stroke_limit_m: float | None = None,
                   fast_path_region: Mapping[str, tuple[float, float]] | None = None,
                   design: Mapping[str, Any] | None = None, **context: Any) -> Validity:
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
    **context
        Passed to registered checks (e.g. a friction check's identified velocity range).
    """
    m = {k: np.atleast_1d(np.asarray(v, dtype=float)) for k, v in metrics.items()
         if np.asarray(v).dtype.kind in "fiub"}
    if "road_holding" not in m:
        raise ValueError("check_validity: metrics need 'road_holding'")
    n = m["road_holding"].size
    ctx = dict(context, stroke_limit_m=stroke_limit_m, fast_path_region=fast_path_region,
               design=design)
    flags: list[list[ValidityFlag]] = [[] for _ in range(n)]
    for code, check in VALIDITY_CHECKS.items():
        for k, msg in enumerate(check(m, ctx)):
            if msg:
                flags[k].append(ValidityFlag(code, msg))
    return Validity(tuple(tuple(f) for f in flags))
