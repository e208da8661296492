"""Generator (DC motor) models of the design space and their rated limits.

The paper varied the speed constant k_n over 29.8–11 900 rpm/V with the winding
resistance R_i and inductance L_i held at the prototype's values.  No real generator does
that: rewinding one frame for a larger voltage constant K_e with the same copper volume
uses N times more turns of a wire N times thinner, so K_e ∝ N, R_i ∝ N², L_i ∝ N²,
while the rotor inertia, the mass and the power rating belong to the frame.

Models (all map a voltage constant K_e to R_i, L_i and rated limits):

:class:`ScalingMotor` (default)
    One frame rewound: R_i = R_i0 (K_e/K_e0)², L_i = L_i0 (K_e/K_e0)², J_m = J_m0;
    rated continuous current ∝ K_e0/K_e (same current density), rated voltage ∝ K_e/K_e0
    (same top speed), rated power fixed.  The reference (K_e0, R_i0, L_i0, J_m0) is the
    user's harvester (``[harvester]`` of the problem, or bench.toml's).
:class:`FixedWindingMotor`
    The paper's assumption: R_i, L_i fixed whatever K_e (labelled as the paper's).
:class:`CatalogueMotor`
    A real generator with datasheet values (K_e, R_i, L_i, J_m, continuous and short-term
    current, nominal and maximum voltage, maximum speed, power, mass, source); a series
    with a winding range (``speed_constant_range_rpm_per_V``) is one frame rewound over
    that range, else its K_e is fixed.  Catalogue motors are designed one run per motor
    (``model = "catalogue"``) or chosen by the optimiser (``model = "select"``,
    :mod:`ehsa_opt.design.selection`).

Limits are checked per sample on the road response (:mod:`ehsa_opt.design.limits`): rms
current ≤ rated continuous current (thermal), the fraction of time beyond the short-term
current and the maximum speed, the road's peak voltage (an extreme-value statistic) ≤ the
maximum voltage, mean electrical power ≤ rated power; the stroke limit is the vehicle's.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .catalogue_file import catalogue_file
from .params import HarvesterParams, ParameterError, check_keys, load_toml

__all__ = ["RatedLimits", "ScalingMotor", "FixedWindingMotor", "CatalogueMotor",
           "MOTOR_MODELS", "load_catalogue", "catalogue_path"]


@dataclass(frozen=True)
class RatedLimits:
    """Rated limits of a generator (None = not limited).

    Attributes
    ----------
    voltage_V : float or None
        Largest terminal voltage (peak), V.
    current_A : float or None
        Rated continuous current (rms: thermal), A.
    power_W : float or None
        Rated continuous power, W (compared with the mean electrical power, load +
        winding).
    """

    voltage_V: float | None = None
    current_A: float | None = None
    power_W: float | None = None

    def __post_init__(self) -> None:
        for name in ("voltage_V", "current_A", "power_W"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v > 0):
                raise ParameterError(f"rated limits: {name} = {v!r} must be a positive "
                                     "number (or absent for no limit)")

    def as_dict(self) -> dict[str, float | None]:
        return {"voltage_V": self.voltage_V, "current_A": self.current_A,
                "power_W": self.power_W}




@dataclass(frozen=True)
class ScalingMotor:
    """One frame, rewound: R_i, L_i ∝ K_e², rated current ∝ 1/K_e, rated voltage ∝ K_e."""

    reference: HarvesterParams = field(default_factory=HarvesterParams)
    rating: RatedLimits = RatedLimits()
    label: str = "scaling law (one frame rewound: R_i, L_i ∝ K_e²)"

    kind = "scaling"

    def winding(self, ke: Any) -> dict[str, np.ndarray]:
        """R_i (Ω), L_i (H) and rated limits (arrays) at voltage constants ``ke``."""
        ke = np.asarray(ke, dtype=float)
        s = ke / self.reference.voltage_constant_Vs_per_rad
        r = self.rating
        nan = np.full(ke.shape, np.nan)
        return {"internal_resistance_ohm": self.reference.internal_resistance_ohm * s * s,
                "inductance_H": self.reference.inductance_H * s * s,
                "rated_current_A": nan if r.current_A is None else r.current_A / s,
                "rated_voltage_V": nan if r.voltage_V is None else r.voltage_V * s,
                "rated_power_W": nan if r.power_W is None else np.full(ke.shape, r.power_W)}

    @property
    def motor_inertia_gcm2(self) -> float:
        return self.reference.motor_inertia_gcm2

    def fingerprint(self) -> dict[str, Any]:
        from dataclasses import asdict
        return {"kind": self.kind, "reference": asdict(self.reference),
                "rating": self.rating.as_dict()}


@dataclass(frozen=True)
class FixedWindingMotor:
    """The paper's design space: R_i and L_i fixed at the reference for every K_e."""

    reference: HarvesterParams = field(default_factory=HarvesterParams)
    rating: RatedLimits = RatedLimits()
    label: str = "paper's assumption (R_i, L_i fixed for every k_n)"

    kind = "paper"

    def winding(self, ke: Any) -> dict[str, np.ndarray]:
        ke = np.asarray(ke, dtype=float)
        r = self.rating
        full = lambda v: np.full(ke.shape, np.nan if v is None else v)  # noqa: E731
        return {"internal_resistance_ohm": np.full(ke.shape,
                                                   self.reference.internal_resistance_ohm),
                "inductance_H": np.full(ke.shape, self.reference.inductance_H),
                "rated_current_A": full(r.current_A), "rated_voltage_V": full(r.voltage_V),
                "rated_power_W": full(r.power_W)}

    @property
    def motor_inertia_gcm2(self) -> float:
        return self.reference.motor_inertia_gcm2

    def fingerprint(self) -> dict[str, Any]:
        from dataclasses import asdict
        return {"kind": self.kind, "reference": asdict(self.reference),
                "rating": self.rating.as_dict()}


@dataclass(frozen=True)
class CatalogueMotor:
    """A real DC generator from a catalogue file (datasheet values, with their source)."""

    name: str
    voltage_constant_Vs_per_rad: float
    internal_resistance_ohm: float
    inductance_H: float
    motor_inertia_gcm2: float
    rating: RatedLimits
    mass_kg: float | None = None
    source: str = ""
    #: largest permissible speed (bearings, commutator), rpm; None = not limited
    max_speed_rpm: float | None = None
    #: short-term (peak) current, A, at this winding; None = not limited
    peak_current_A: float | None = None
    #: speed constants (rpm/V) of the windings the series offers, (lowest, highest); None:
    #: only this winding
    speed_constant_range_rpm_per_V: tuple[float, float] | None = None
    #: largest terminal voltage, V, at this winding; None: the back-EMF at the maximum
    #: speed K_e ω_max (a generator's voltage is its back-EMF less the winding drop, and
    #: the nominal voltage is the one the ratings are stated at, not a maximum), else the
    #: nominal voltage
    max_voltage_V: float | None = None

    kind = "catalogue"

    @property
    def label(self) -> str:
        return f"catalogue: {self.name}"

    @property
    def rewindable(self) -> bool:
        """The series offers other windings (a winding range is given)."""
        r = self.speed_constant_range_rpm_per_V
        return r is not None and r[1] > r[0]

    def speed_constant_at(self, u: Any) -> np.ndarray:
        """k_n (rpm/V) at a unit winding coordinate ``u`` (0: lowest k_n of the range,
        1: highest; logarithmic); this winding's k_n without a range."""
        u = np.clip(np.asarray(u, dtype=float), 0.0, 1.0)
        if not self.rewindable:
            return np.full(u.shape, self.speed_constant_rpm_per_V)
        lo, hi = self.speed_constant_range_rpm_per_V  # type: ignore[misc]
        return lo * (hi / lo) ** u

    def winding(self, ke: Any = None) -> dict[str, np.ndarray]:
        """R_i, L_i and the limits at voltage constants ``ke`` (V s/rad): this winding's
        values, or (a series with a winding range) the frame rewound from it, s = K_e/K_e0:
        R_i, L_i ∝ s², currents ∝ 1/s, voltage ∝ s, speed and power fixed."""
        shape = np.shape(ke) if ke is not None else ()
        s = (np.ones(shape) if ke is None or not self.rewindable
             else np.asarray(ke, dtype=float) / self.voltage_constant_Vs_per_rad)
        r = self.rating

        def full(v: float | None, power: int = 0) -> np.ndarray:
            return np.full(shape, np.nan) if v is None else float(v) * s ** power
        return {"internal_resistance_ohm": full(self.internal_resistance_ohm, 2),
                "inductance_H": full(self.inductance_H, 2),
                "rated_current_A": full(r.current_A, -1), "rated_voltage_V": full(r.voltage_V, 1),
                "rated_power_W": full(r.power_W), "peak_current_A": full(self.peak_current_A, -1),
                "max_speed_rpm": full(self.max_speed_rpm),
                "max_voltage_V": full(self.voltage_limit_V, 1)}

    @property
    def voltage_limit_V(self) -> float | None:
        """Largest terminal voltage at this winding (see :attr:`max_voltage_V`), V."""
        if self.max_voltage_V is not None:
            return self.max_voltage_V
        if self.max_speed_rpm is not None:
            return self.voltage_constant_Vs_per_rad * self.max_speed_rpm * math.pi / 30.0
        return self.rating.voltage_V

    @property
    def speed_constant_rpm_per_V(self) -> float:
        return 60.0 / (2.0 * math.pi * self.voltage_constant_Vs_per_rad)

    def harvester(self, base: HarvesterParams) -> HarvesterParams:
        """``base`` with this motor's winding, constants and rotor inertia."""
        return base.replace(voltage_constant_Vs_per_rad=self.voltage_constant_Vs_per_rad,
                            torque_constant_Nm_per_A=self.voltage_constant_Vs_per_rad,
                            internal_resistance_ohm=self.internal_resistance_ohm,
                            inductance_H=self.inductance_H,
                            motor_inertia_gcm2=self.motor_inertia_gcm2)

    def fingerprint(self) -> dict[str, Any]:
        from dataclasses import asdict
        d = asdict(self)
        d["kind"] = self.kind
        return d


MOTOR_MODELS: tuple[str, ...] = ("scaling", "paper", "catalogue", "select")

_MOTOR_KEYS = ("name", "speed_constant_rpm_per_V", "voltage_constant_Vs_per_rad",
               "internal_resistance_ohm", "inductance_H", "motor_inertia_gcm2",
               "rated_voltage_V", "rated_current_A", "rated_power_W", "mass_kg", "source",
               "notes", "peak_current_A", "max_speed_rpm", "speed_constant_range_rpm_per_V",
               "max_voltage_V")


def _winding_range(m: dict, where: str, ke: float) -> tuple[float, float] | None:
    """``speed_constant_range_rpm_per_V = [lo, hi]``: two positive numbers holding the
    motor's own k_n (the winding the datasheet values belong to)."""
    if "speed_constant_range_rpm_per_V" not in m:
        return None
    v = m["speed_constant_range_rpm_per_V"]
    if (not isinstance(v, list) or len(v) != 2
            or not all(isinstance(x, (int, float)) and not isinstance(x, bool)
                       and math.isfinite(x) and x > 0 for x in v) or v[0] > v[1]):
        raise ParameterError(f"{where}: 'speed_constant_range_rpm_per_V' = {v!r} must be "
                             "[lowest, highest] k_n of the series' windings (rpm/V, > 0)")
    kn = 60.0 / (2.0 * math.pi * ke)
    if not v[0] * (1 - 1e-3) <= kn <= v[1] * (1 + 1e-3):
        raise ParameterError(f"{where}: the winding range {v} rpm/V does not hold the motor's "
                             f"own k_n = {kn:.4g} rpm/V; the datasheet values are those of one "
                             "winding of the range")
    return (float(v[0]), float(v[1]))


def catalogue_path(name: str | Path = "dc_generators", base_dir: str | Path | None = None
                   ) -> Path:
    """A catalogue file: the name of one shipped in ``ehsa_opt/data/motors`` (a bare name
    such as ``"dc_generators"``), or a path (a ``.toml`` name or one with a folder),
    resolved against ``base_dir`` (the folder of the file naming it) when relative.  A path
    must lead to an existing file: it never falls back on a shipped catalogue."""
    return catalogue_file("motor catalogue", "motors", "dc_generators", name, base_dir)


def load_catalogue(path: str | Path = "dc_generators", base_dir: str | Path | None = None
                   ) -> list[CatalogueMotor]:
    """Read a motor catalogue (TOML, one ``[[motor]]`` table per generator; the format:
    docs/formats.md).

    Each motor: ``name``, ``speed_constant_rpm_per_V`` or ``voltage_constant_Vs_per_rad``,
    ``internal_resistance_ohm``, ``inductance_H``, ``motor_inertia_gcm2``, the ratings
    ``rated_voltage_V``, ``rated_current_A`` (continuous), ``rated_power_W`` (each
    optional), ``mass_kg`` (optional) and ``source`` (required: where the values come
    from).  The file is read through the shared limits (size, UTF-8, nesting:
    :func:`~ehsa_opt.physics.params.load_toml`); bad entries are refused naming the file,
    the motor and the key.
    """
    p = catalogue_path(path, base_dir)
    doc = load_toml(p, "motor catalogue")
    check_keys(doc, ("motor", "title", "description"), str(p))
    motors = doc.get("motor")
    if not isinstance(motors, list) or not motors:
        raise ParameterError(f"{p}: no [[motor]] tables; add at least one motor")
    out = []
    for k, m in enumerate(motors):
        if not isinstance(m, dict):
            raise ParameterError(f"{p}: motor #{k + 1} is {m!r:.40}, not a table; write each "
                                 f"generator as a [[motor]] table of key = value pairs")
        label = m.get("name") if isinstance(m.get("name"), str) else "unnamed"
        where = f"{p} [[motor]] #{k + 1} ({label[:60]})"
        check_keys(m, _MOTOR_KEYS, where)
        for key in ("name", "source"):
            if not isinstance(m.get(key), str) or not m[key].strip():
                raise ParameterError(f"{where}: '{key}' is required (text); every motor "
                                     "states where its datasheet values come from")
        if ("speed_constant_rpm_per_V" in m) == ("voltage_constant_Vs_per_rad" in m):
            raise ParameterError(f"{where}: give exactly one of speed_constant_rpm_per_V and "
                                 "voltage_constant_Vs_per_rad")

        def num(key: str, required: bool = True) -> float | None:
            if key not in m:
                if required:
                    raise ParameterError(f"{where}: '{key}' is required")
                return None
            v = m[key]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not v > 0 \
                    or not math.isfinite(v):
                raise ParameterError(f"{where}: '{key}' = {v!r} must be a positive number")
            return float(v)
        ke = (60.0 / (2.0 * math.pi * num("speed_constant_rpm_per_V"))
              if "speed_constant_rpm_per_V" in m else num("voltage_constant_Vs_per_rad"))
        out.append(CatalogueMotor(
            name=m["name"], voltage_constant_Vs_per_rad=float(ke),
            internal_resistance_ohm=float(num("internal_resistance_ohm")),
            inductance_H=float(num("inductance_H")),
            motor_inertia_gcm2=float(num("motor_inertia_gcm2")),
            rating=RatedLimits(num("rated_voltage_V", False), num("rated_current_A", False),
                               num("rated_power_W", False)),
            mass_kg=num("mass_kg", False), source=m["source"].strip(),
            max_speed_rpm=num("max_speed_rpm", False),
            peak_current_A=num("peak_current_A", False),
            max_voltage_V=num("max_voltage_V", False),
            speed_constant_range_rpm_per_V=_winding_range(m, where, ke)))
        try:  # the ranges every harvester obeys (units: a slip of 1000 is refused here)
            out[-1].harvester(HarvesterParams())
        except ParameterError as exc:
            raise ParameterError(f"{where}: {str(exc).split(': ', 1)[-1]}") from None
    names = [m.name for m in out]
    if len(set(names)) != len(names):
        raise ParameterError(f"{p}: duplicate motor names")
    return out
