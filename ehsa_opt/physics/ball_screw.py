"""Ball screws of the design space: geometry, speed limits and their catalogue.

A ball screw turns at ω = v / r (r = lead / 2π) for a stroke velocity v; it may not turn
faster than the lower of

* the DN limit: n ≤ DN / d0 (d0 the nominal diameter in mm, DN the ball-recirculation
  limit of the series, mm·rpm), and
* the critical (whirling) speed with a margin: n ≤ 0.8 n_c, n_c = f d_r / L² × 10⁷ rpm
  (d_r root diameter and L unsupported length in mm; f set by the mounting).

The formula, the mounting factors and the 80 % margin are the screw makers' (HIWIN
Ballscrews Technical Information, "permissible speed").  The screw's own inertia is that
of a steel cylinder of the root diameter over the unsupported length.

Its fatigue life is the nominal life of ISO 3408-5 (HIWIN "service life"): 90 % of screws
reach L10 = (C_dyn / F_m)³ × 10⁶ revolutions under the cubic mean axial load F_m (the
load weighted by the revolutions run under it, F_m³ = Σ |F|³ n / Σ n), C_dyn the
dynamic load rating of the nut.  A design needs L10 at least the revolutions it turns over
its required service life; equivalently F_m at most :func:`allowable_mean_load`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .catalogue_file import catalogue_file
from .params import ParameterError, check_keys, load_toml, nearest_name

__all__ = ["MOUNTING_FACTORS", "CRITICAL_SPEED_MARGIN", "STEEL_DENSITY_KG_M3", "BallScrew",
           "load_screws", "screw_catalogue_path", "l10_revolutions", "allowable_mean_load"]

#: Factor f of the critical speed n_c = f d_r / L² × 10⁷ rpm per mounting of the shaft ends
#: (HIWIN Ballscrews Technical Information).
MOUNTING_FACTORS: dict[str, float] = {"fixed-fixed": 21.9, "fixed-supported": 15.1,
                                      "supported-supported": 9.7, "fixed-free": 3.4}
#: Share of the critical speed a screw may run at (the makers' 80 %).
CRITICAL_SPEED_MARGIN = 0.8
#: Density of the screw shaft (bearing steel), kg/m³.
STEEL_DENSITY_KG_M3 = 7850.0


@dataclass(frozen=True)
class BallScrew:
    """One ball screw with its datasheet geometry and limits.

    Attributes
    ----------
    name, source : str
        Its designation and where the values come from.
    lead_mm_per_rev, nominal_diameter_mm, root_diameter_mm : float
        Lead (mm/rev), nominal (d0) and root (d_r) diameters (mm).
    dn_limit : float
        DN limit of the series, mm·rpm.
    unsupported_length_mm : float
        Free length of the shaft between its supports (or to its free end), mm.
    mounting : str
        One of :data:`MOUNTING_FACTORS`.
    dynamic_load_rating_N : float or None
        Dynamic load rating C_dyn of the nut, N (the L10 life of :func:`l10_revolutions`);
        None: the screw's fatigue life is not checked.
    """

    name: str
    lead_mm_per_rev: float
    nominal_diameter_mm: float
    root_diameter_mm: float
    dn_limit: float
    unsupported_length_mm: float
    mounting: str
    source: str
    dynamic_load_rating_N: float | None = None

    @property
    def critical_speed_rpm(self) -> float:
        """Whirling speed n_c = f d_r / L² × 10⁷, rpm."""
        return (MOUNTING_FACTORS[self.mounting] * self.root_diameter_mm
                / self.unsupported_length_mm ** 2 * 1e7)

    @property
    def dn_speed_rpm(self) -> float:
        """Speed of the DN limit, DN / d0, rpm."""
        return self.dn_limit / self.nominal_diameter_mm

    @property
    def max_speed_rpm(self) -> float:
        """Permissible speed: min(DN / d0, 0.8 n_c), rpm."""
        return min(self.dn_speed_rpm, CRITICAL_SPEED_MARGIN * self.critical_speed_rpm)

    @property
    def inertia_gcm2(self) -> float:
        """Shaft inertia (steel cylinder of the root diameter, unsupported length), g cm²."""
        d, length = 1e-3 * self.root_diameter_mm, 1e-3 * self.unsupported_length_mm
        return math.pi * STEEL_DENSITY_KG_M3 * length * d ** 4 / 32.0 * 1e7

    def as_dict(self) -> dict[str, Any]:
        from dataclasses import asdict
        return {**asdict(self), "max_speed_rpm": self.max_speed_rpm,
                "critical_speed_rpm": self.critical_speed_rpm, "inertia_gcm2": self.inertia_gcm2}


def l10_revolutions(dynamic_load_rating_N: Any, mean_load_N: Any) -> np.ndarray:
    """Nominal (90 % survival) life L10 = (C_dyn / F_m)³ × 10⁶ of a ball screw, revolutions
    (ISO 3408-5; see module)."""
    c, f = np.asarray(dynamic_load_rating_N, float), np.asarray(mean_load_N, float)
    with np.errstate(divide="ignore"):
        return np.where(f > 0, (c / np.where(f > 0, f, 1.0)) ** 3 * 1e6, np.inf)


def allowable_mean_load(dynamic_load_rating_N: Any, revolutions: Any) -> np.ndarray:
    """The cubic mean axial load F_m at which L10 equals ``revolutions``:
    C_dyn (10⁶ / revolutions)^(1/3), N (the inverse of :func:`l10_revolutions`)."""
    c, n = np.asarray(dynamic_load_rating_N, float), np.asarray(revolutions, float)
    with np.errstate(divide="ignore"):
        return np.where(n > 0, c * np.cbrt(1e6 / np.where(n > 0, n, 1.0)), np.inf)


_KEYS = ("name", "lead_mm_per_rev", "nominal_diameter_mm", "root_diameter_mm", "dn_limit",
         "unsupported_length_mm", "mounting", "source", "dynamic_load_rating_N", "notes")


def screw_catalogue_path(name: str | Path = "ball_screws", base_dir: str | Path | None = None
                         ) -> Path:
    """A screw catalogue: a shipped one by bare name (``"ball_screws"``) or a path (relative
    to ``base_dir``); a path must exist."""
    return catalogue_file("screw catalogue", "screws", "ball_screws", name, base_dir)


def load_screws(path: str | Path = "ball_screws", base_dir: str | Path | None = None
                ) -> list[BallScrew]:
    """Read a screw catalogue (TOML, one ``[[screw]]`` table per screw; docs/formats.md);
    bad entries are refused naming the file, the screw and the key."""
    p = screw_catalogue_path(path, base_dir)
    doc = load_toml(p, "screw catalogue")
    check_keys(doc, ("screw", "title", "description"), str(p))
    screws = doc.get("screw")
    if not isinstance(screws, list) or not screws:
        raise ParameterError(f"{p}: no [[screw]] tables; add at least one screw")
    out = []
    for k, s in enumerate(screws):
        if not isinstance(s, dict):
            raise ParameterError(f"{p}: screw #{k + 1} is not a table")
        label = s.get("name") if isinstance(s.get("name"), str) else "unnamed"
        where = f"{p} [[screw]] #{k + 1} ({label[:60]})"
        check_keys(s, _KEYS, where)
        for key in ("name", "source", "mounting"):
            if not isinstance(s.get(key), str) or not s[key].strip():
                raise ParameterError(f"{where}: '{key}' is required (text)")
        if s["mounting"] not in MOUNTING_FACTORS:
            near = nearest_name(s["mounting"], tuple(MOUNTING_FACTORS))
            raise ParameterError(f"{where}: mounting '{s['mounting']}' unknown"
                                 + (f"; did you mean '{near}'?" if near else "")
                                 + f" (valid: {', '.join(MOUNTING_FACTORS)})")

        def num(key: str, required: bool = True) -> float | None:
            if key not in s:
                if required:
                    raise ParameterError(f"{where}: '{key}' is required")
                return None
            v = s[key]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0 \
                    or not math.isfinite(v):
                raise ParameterError(f"{where}: '{key}' = {v!r} must be a positive number")
            return float(v)
        screw = BallScrew(s["name"], num("lead_mm_per_rev"), num("nominal_diameter_mm"),
                          num("root_diameter_mm"), num("dn_limit"),
                          num("unsupported_length_mm"), s["mounting"], s["source"].strip(),
                          num("dynamic_load_rating_N", False))
        if screw.root_diameter_mm >= screw.nominal_diameter_mm:
            raise ParameterError(f"{where}: root_diameter_mm must be below "
                                 "nominal_diameter_mm")
        out.append(screw)
    names = [s.name for s in out]
    if len(set(names)) != len(names):
        raise ParameterError(f"{p}: duplicate screw names")
    return out
