"""Parameter sets as frozen dataclasses with units in their names.

Every field name carries its unit, every value is validated when the
object is built, and every error says what to change.  The TOML loaders accept
exactly these names; an unknown key is refused with the nearest valid name.

Classes
-------
HarvesterParams
    The ball-screw harvester (paper Table 1 defaults), with the equivalent
    mechanical quantities of paper Eqs 1–3.
FrictionParams
    The eight Simscape friction parameters of the nut–screw pair and the
    generator bearings.
VehicleParams
    Quarter-car masses and stiffnesses, with the vehicle presets (assumptions: the paper's vehicle values are not published).
RoadParams
    An ISO 8608 road (class, speed, length, seed) or a measured profile CSV.
"""

from __future__ import annotations

import dataclasses
import difflib
import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from .base_parameters import PARAMETERS

__all__ = [
    "ParameterError",
    "HarvesterParams",
    "FrictionParams",
    "VehicleParams",
    "RoadParams",
    "VEHICLE_PRESETS",
    "FRICTION_NAMES",
    "FRICTION_LAW_NAMES",
    "PRESLIDING_PARAMETER_NAMES",
    "FRICTION_RANGES",
    "ISO_CLASSES",
    "ISO_CLASS_LEVELS",
    "from_mapping",
    "load_toml",
    "nearest_name",
    "unknown_name_message",
    "check_keys",
]


class ParameterError(ValueError):
    """A parameter value or key is invalid; the message says how to fix it."""


def nearest_name(key: str, valid: list[str] | tuple[str, ...]) -> str | None:
    """Return the valid name closest to ``key`` (for 'did you mean' hints)."""
    match = difflib.get_close_matches(key, list(valid), n=1, cutoff=0.4)
    return match[0] if match else None


def unknown_name_message(key: str, valid: Any, where: str, what: str = "key") -> str:
    """``"{where}: unknown {what} '{key}'; did you mean '...'? (valid: ...)"``."""
    valid = tuple(valid)
    key = str(key)
    near = nearest_name(key, valid) if len(key) <= 200 else None
    shown = repr(key[:60])[1:-1] + (f"... ({len(key)} characters)" if len(key) > 60 else "")
    hint = f"; did you mean '{near}'?" if near else ""
    return f"{where}: unknown {what} '{shown}'{hint} (valid: {', '.join(valid)})"


def check_keys(table: Any, valid: Any, where: str, error: type[Exception] | None = None) -> None:
    """Refuse a non-table or any key of ``table`` not in ``valid`` (nearest name in the
    message). ``error`` is the exception class (default :class:`ParameterError`)."""
    error = error or ParameterError
    if not isinstance(table, Mapping):
        raise error(f"{where}: expected a table of key = value pairs")
    valid = tuple(valid)
    for key in table:
        if key not in valid:
            raise error(unknown_name_message(key, valid, where))


def _spec(unit: str, doc: str, *, gt: float | None = None, ge: float | None = None,
          le: float | None = None, lt: float | None = None, hint: str = "",
          allow_inf: bool = False) -> dict:
    """Metadata of a numeric field: unit, description and admissible range."""
    return {"unit": unit, "doc": doc, "gt": gt, "ge": ge, "le": le, "lt": lt, "hint": hint,
            "allow_inf": allow_inf}


def _num(default: float, unit: str, doc: str, **kw: Any) -> Any:
    return field(default=default, metadata=_spec(unit, doc, **kw))


def _validate_numbers(obj: Any, where: str) -> None:
    """Check every numeric field of a dataclass against its metadata range."""
    for f in dataclasses.fields(obj):
        md = f.metadata
        if "unit" not in md:
            continue
        value = getattr(obj, f.name)
        if value is None:
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ParameterError(
                f"{where}: '{f.name}' must be a number in {md['unit']}, got {value!r}; "
                f"write e.g. {f.name} = {f.default!r}")
        value = float(value)
        if not math.isfinite(value) and not (md["allow_inf"] and value == math.inf):
            raise ParameterError(f"{where}: '{f.name}' = {value} is not finite; give a finite "
                                 f"value in {md['unit']}")
        bad = None
        if md["gt"] is not None and not value > md["gt"]:
            bad = f"must be > {md['gt']:g} {md['unit']}"
        elif md["ge"] is not None and not value >= md["ge"]:
            bad = f"must be >= {md['ge']:g} {md['unit']}"
        elif md["lt"] is not None and not value < md["lt"]:
            bad = f"must be < {md['lt']:g} {md['unit']}"
        elif md["le"] is not None and not value <= md["le"]:
            bad = f"must be <= {md['le']:g} {md['unit']}"
        if bad:
            hint = f" ({md['hint']})" if md["hint"] else ""
            raise ParameterError(f"{where}: '{f.name}' = {value:g} {bad}{hint}")
        object.__setattr__(obj, f.name, value)


# --------------------------------------------------------------------------- harvester
@dataclass(frozen=True)
class HarvesterParams:
    """Ball-screw energy-harvesting shock absorber (paper Table 1 defaults).

    Equivalent mechanical system (paper Eqs 1–3), r = lead / 2π in m/rad,
    R = R_e + R_i, ω the excitation frequency in rad/s::

        m_eq    = (J_m + J_s) / r²
        c_eq(ω) = K_t K_e R / (r² (R² + L_i² ω²))
        k_eq(ω) = K_t K_e L_i ω² / (r² (R² + L_i² ω²))

    Attributes
    ----------
    motor_inertia_gcm2, screw_inertia_gcm2 : float
        Rotor and screw inertia, g cm².
    lead_mm_per_rev : float
        Screw lead, mm per revolution.
    internal_resistance_ohm : float
        Winding resistance R_i, Ω.
    voltage_constant_Vs_per_rad, torque_constant_Nm_per_A : float
        K_e (V s/rad) and K_t (N m/A).
    inductance_H : float
        Winding inductance L_i, H (0 allowed: quasi-static electrical state).
    load_ohm : float
        External load R_e, Ω (``math.inf`` for open circuit, 0 for short circuit).
    """

    motor_inertia_gcm2: float = _num(121.0, "g cm^2", "motor rotor inertia J_m", ge=0.0,
                                     le=1e6, hint="inertia is in g cm^2: 1 kg m^2 = 1e7 g cm^2")
    screw_inertia_gcm2: float = _num(180.0, "g cm^2", "screw inertia J_s", ge=0.0, le=1e6,
                                     hint="inertia is in g cm^2: 1 kg m^2 = 1e7 g cm^2")
    lead_mm_per_rev: float = _num(5.0, "mm/rev", "screw lead", gt=0.0, le=200.0,
                                  hint="lead is in mm per revolution, e.g. 5.0")
    internal_resistance_ohm: float = _num(6.6, "ohm", "winding resistance R_i", ge=0.0, le=1e4)
    voltage_constant_Vs_per_rad: float = _num(0.137, "V s/rad", "voltage constant K_e", gt=0.0,
                                              le=100.0, hint="catalogue speed constant k_n in "
                                              "rpm/V converts as K_e = 60 / (2 pi k_n)")
    torque_constant_Nm_per_A: float = _num(0.137, "N m/A", "torque constant K_t", gt=0.0, le=100.0)
    inductance_H: float = _num(1.7e-3, "H", "winding inductance L_i", ge=0.0, le=1.0,
                               hint="inductance is in henry: 1.7 mH = 0.0017")
    load_ohm: float = _num(47.0, "ohm", "external load R_e", ge=0.0, allow_inf=True,
                           hint="use inf for open circuit, 0 for short circuit")

    def __post_init__(self) -> None:
        _validate_numbers(self, "harvester")
        if self.total_inertia_gcm2 <= 0.0:
            raise ParameterError("harvester: motor_inertia_gcm2 + screw_inertia_gcm2 must be > 0")

    # -- derived quantities (SI) -------------------------------------------------------
    @property
    def lead_m_per_rad(self) -> float:
        """r = lead / 2π, m/rad."""
        return self.lead_mm_per_rev * 1e-3 / (2.0 * math.pi)

    @property
    def total_inertia_gcm2(self) -> float:
        """J_t = J_m + J_s, g cm²."""
        return self.motor_inertia_gcm2 + self.screw_inertia_gcm2

    @property
    def total_inertia_kgm2(self) -> float:
        """J_t in kg m²."""
        return self.total_inertia_gcm2 * 1e-7

    @property
    def speed_constant_rpm_per_V(self) -> float:
        """k_n = 60 / (2π K_e), rpm/V."""
        return 60.0 / (2.0 * math.pi * self.voltage_constant_Vs_per_rad)

    def equivalent_mass_kg(self) -> float:
        """m_eq = J_t / r² (paper Eq 1), kg."""
        return self.total_inertia_kgm2 / self.lead_m_per_rad ** 2

    def total_resistance_ohm(self, load_ohm: float | None = None) -> float:
        """R = R_e + R_i, Ω."""
        return (self.load_ohm if load_ohm is None else load_ohm) + self.internal_resistance_ohm

    def _coupling(self, load_ohm: float | None) -> tuple[float, float]:
        """(K_t K_e / r², R) of the electrical coupling; R = inf for open circuit."""
        kk = self.torque_constant_Nm_per_A * self.voltage_constant_Vs_per_rad
        return kk / self.lead_m_per_rad ** 2, self.total_resistance_ohm(load_ohm)

    def equivalent_damping_Ns_per_m(self, omega_rad_s: Any = 0.0,
                                    load_ohm: float | None = None) -> Any:
        """c_eq(ω) of paper Eq 2, N s/m (0 for open circuit). Vectorised over ω."""
        g, R = self._coupling(load_ohm)
        if math.isinf(R):
            return 0.0 * omega_rad_s
        return g * R / (R ** 2 + (self.inductance_H * omega_rad_s) ** 2)

    def equivalent_stiffness_N_per_m(self, omega_rad_s: Any = 0.0,
                                     load_ohm: float | None = None) -> Any:
        """k_eq(ω) of paper Eq 3, N/m (0 for open circuit). Vectorised over ω."""
        g, R = self._coupling(load_ohm)
        if math.isinf(R):
            return 0.0 * omega_rad_s
        L = self.inductance_H
        return g * L * omega_rad_s ** 2 / (R ** 2 + (L * omega_rad_s) ** 2)

    def replace(self, **changes: Any) -> "HarvesterParams":
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    @classmethod
    def from_design(cls, total_inertia_gcm2: float, lead_mm_per_rev: float,
                    speed_constant_rpm_per_V: float, load_ohm: float,
                    base: "HarvesterParams | None" = None) -> "HarvesterParams":
        """Harvester from the paper's design variables (Table 3).

        The total inertia is split in the base design's motor/screw ratio;
        K_e = K_t = 60 / (2π k_n); R_i and L_i come from ``base``.
        """
        base = base or cls()
        share = base.motor_inertia_gcm2 / base.total_inertia_gcm2
        ke = 60.0 / (2.0 * math.pi * speed_constant_rpm_per_V)
        return dataclasses.replace(
            base, motor_inertia_gcm2=total_inertia_gcm2 * share,
            screw_inertia_gcm2=total_inertia_gcm2 * (1.0 - share),
            lead_mm_per_rev=lead_mm_per_rev, voltage_constant_Vs_per_rad=ke,
            torque_constant_Nm_per_A=ke, load_ohm=load_ohm)


# --------------------------------------------------------------------------- friction
FRICTION_NAMES: tuple[str, ...] = (
    "nut_breakaway_N", "nut_coulomb_N", "nut_breakaway_velocity_m_per_s", "nut_viscous_Ns_per_m",
    "bearing_breakaway_Nm", "bearing_coulomb_Nm", "bearing_breakaway_velocity_rad_per_s",
    "bearing_viscous_Nms_per_rad",
)

#: Friction laws a friction set may name (the models' list is
#: :data:`~ehsa_opt.physics.friction.FRICTION_LAWS`; the same two).
_FRICTION_LAWS: tuple[str, ...] = ("static", "lugre")
#: Parameters of the LuGre law in a friction set (declared in
#: :data:`~ehsa_opt.physics.base_parameters.PARAMETERS`).
PRESLIDING_PARAMETER_NAMES: tuple[str, ...] = ("presliding_stiffness_N_per_m",
                                               "presliding_damping_Ns_per_m")
#: Every key of a friction set: the eight of the map, the law and its parameters.
FRICTION_LAW_NAMES: tuple[str, ...] = ("friction_law", *PRESLIDING_PARAMETER_NAMES)

#: Distributor ranges for random initial points (an assumption): the start ranges of
#: :data:`~ehsa_opt.physics.base_parameters.PARAMETERS`.
FRICTION_RANGES: dict[str, tuple[float, float]] = {n: PARAMETERS[n].start for n in FRICTION_NAMES}


def _declared(name: str, default: float) -> Any:
    """A friction field validated against the declaration's physical bounds."""
    q = PARAMETERS[name]
    low = {"gt": q.lower} if q.lower_open else {"ge": q.lower}
    return _num(default, q.unit, q.doc, le=q.upper, hint=q.hint, **low)


@dataclass(frozen=True)
class FrictionParams:
    """Simscape friction of the nut–screw pair and the generator bearings.

    For a velocity u (m/s at the nut, rad/s at the bearings)::

        F(u) = √(2e) (F_brk − F_C) exp(−(u/u_St)²) (u/u_St) + F_C tanh(u/u_Coul) + f_v u
        u_St = √2 u_brk,   u_Coul = u_brk / 10

    Constraints: breakaway ≥ Coulomb ≥ 0, breakaway velocities > 0, viscous ≥ 0.
    The defaults are the frictionless case.  Units, physical bounds and start ranges are
    those of :data:`~ehsa_opt.physics.base_parameters.PARAMETERS`.

    Friction law (:data:`FRICTION_LAW_NAMES`): ``friction_law = "static"`` (the default)
    is the map above; ``"lugre"`` makes that map the steady state of a LuGre bristle of
    stiffness ``presliding_stiffness_N_per_m`` (σ₀, N/m) and damping
    ``presliding_damping_Ns_per_m`` (σ₁, N s/m) carrying the rod's whole friction
    (:mod:`~ehsa_opt.physics.friction`); both are required with ``"lugre"`` and refused
    with ``"static"``.  The static law is the limit σ₀ → ∞.  :meth:`as_array` and
    :meth:`as_dict` hold the eight parameters of the map only; :meth:`law_dict` the law.
    """

    nut_breakaway_N: float = _declared("nut_breakaway_N", 0.0)
    nut_coulomb_N: float = _declared("nut_coulomb_N", 0.0)
    nut_breakaway_velocity_m_per_s: float = _declared("nut_breakaway_velocity_m_per_s", 0.01)
    nut_viscous_Ns_per_m: float = _declared("nut_viscous_Ns_per_m", 0.0)
    bearing_breakaway_Nm: float = _declared("bearing_breakaway_Nm", 0.0)
    bearing_coulomb_Nm: float = _declared("bearing_coulomb_Nm", 0.0)
    bearing_breakaway_velocity_rad_per_s: float = _declared("bearing_breakaway_velocity_rad_per_s",
                                                            1.0)
    bearing_viscous_Nms_per_rad: float = _declared("bearing_viscous_Nms_per_rad", 0.0)
    friction_law: str = "static"
    presliding_stiffness_N_per_m: float | None = _declared("presliding_stiffness_N_per_m", None)
    presliding_damping_Ns_per_m: float | None = _declared("presliding_damping_Ns_per_m", None)

    def __post_init__(self) -> None:
        _validate_numbers(self, "friction")
        law = self.friction_law
        if law not in _FRICTION_LAWS:
            raise ParameterError(f"friction: friction_law = {law!r} is not a friction law; use "
                                 f"one of {', '.join(repr(x) for x in _FRICTION_LAWS)}")
        given = [n for n in PRESLIDING_PARAMETER_NAMES if getattr(self, n) is not None]
        if law == "static" and given:
            raise ParameterError(f"friction: {', '.join(given)} belong(s) to the LuGre law; "
                                 f"set friction_law = \"lugre\" or remove them")
        if law == "lugre" and len(given) < len(PRESLIDING_PARAMETER_NAMES):
            missing = [n for n in PRESLIDING_PARAMETER_NAMES if n not in given]
            raise ParameterError(f"friction: friction_law = \"lugre\" needs "
                                 f"{', '.join(missing)} (bristle stiffness sigma_0 in N/m, "
                                 f"damping sigma_1 in N s/m)")
        if self.nut_breakaway_N < self.nut_coulomb_N:
            raise ParameterError(
                f"friction: nut_breakaway_N ({self.nut_breakaway_N:g}) must be >= nut_coulomb_N "
                f"({self.nut_coulomb_N:g}); raise the breakaway force or lower the Coulomb force")
        if self.bearing_breakaway_Nm < self.bearing_coulomb_Nm:
            raise ParameterError(
                f"friction: bearing_breakaway_Nm ({self.bearing_breakaway_Nm:g}) must be >= "
                f"bearing_coulomb_Nm ({self.bearing_coulomb_Nm:g})")

    def as_array(self) -> list[float]:
        """The eight values in :data:`FRICTION_NAMES` order."""
        return [getattr(self, n) for n in FRICTION_NAMES]

    @classmethod
    def from_array(cls, values: Any) -> "FrictionParams":
        """Inverse of :meth:`as_array`."""
        return cls(**{n: float(v) for n, v in zip(FRICTION_NAMES, values, strict=True)})

    def as_dict(self) -> dict[str, float]:
        """The eight parameters of the map by name (the law: :meth:`law_dict`)."""
        return dict(zip(FRICTION_NAMES, self.as_array()))

    def law_dict(self) -> dict[str, Any]:
        """``{}`` for the static law; else ``friction_law`` and its parameters by name."""
        if self.friction_law == "static":
            return {}
        return {"friction_law": self.friction_law,
                **{n: getattr(self, n) for n in PRESLIDING_PARAMETER_NAMES}}

    def with_law(self, law: str = "static", **parameters: float) -> "FrictionParams":
        """The same map under ``law`` with its parameters (none for ``"static"``)."""
        keep = {n: None for n in PRESLIDING_PARAMETER_NAMES}
        keep.update(parameters)
        return dataclasses.replace(self, friction_law=law, **keep)

    @property
    def is_static(self) -> bool:
        """True under the static law."""
        return self.friction_law == "static"

    @property
    def is_frictionless(self) -> bool:
        return all(getattr(self, n) == 0.0 for n in FRICTION_NAMES if "velocity" not in n)


# --------------------------------------------------------------------------- vehicle
@dataclass(frozen=True)
class VehicleParams:
    """Quarter car: sprung mass m2, unsprung mass m1, k2, k1, and the suspension's stroke
    limit (the largest |x2 − x1| from static; a result beyond it hits the bump stops,
    which the model does not have, and is flagged invalid)."""

    sprung_mass_kg: float = _num(375.0, "kg", "sprung mass m2", gt=0.0, le=1e5)
    unsprung_mass_kg: float = _num(45.0, "kg", "unsprung mass m1", gt=0.0, le=1e4)
    suspension_stiffness_N_per_m: float = _num(22e3, "N/m", "suspension stiffness k2", gt=0.0,
                                               le=1e8)
    tyre_stiffness_N_per_m: float = _num(200e3, "N/m", "tyre stiffness k1", gt=0.0, le=1e9)
    stroke_limit_m: float = _num(0.1, "m", "suspension stroke limit |x2 - x1| "
                                 "(assumption: +/-100 mm, a passenger car's bump-to-rebound "
                                 "travel is about 200 mm)", gt=0.0, le=2.0,
                                 hint="the stroke limit is in metres, e.g. 0.1")

    def __post_init__(self) -> None:
        _validate_numbers(self, "vehicle")
        for name, least, what in (("sprung_mass_kg", 1.0, "a quarter of a vehicle's body"),
                                  ("unsprung_mass_kg", 0.1, "a wheel, hub and brake")):
            if getattr(self, name) < least:
                raise ParameterError(
                    f"vehicle: '{name}' = {getattr(self, name):g} kg is implausible for "
                    f"{what}; it must be >= {least:g} kg (masses are in kg)")

    @classmethod
    def preset(cls, name: str) -> "VehicleParams":
        """One of :data:`VEHICLE_PRESETS` by name."""
        if name not in VEHICLE_PRESETS:
            raise ParameterError(unknown_name_message(name, VEHICLE_PRESETS, "vehicle", "preset"))
        return VEHICLE_PRESETS[name]

    @property
    def total_mass_kg(self) -> float:
        return self.sprung_mass_kg + self.unsprung_mass_kg


VEHICLE_PRESETS: dict[str, VehicleParams] = {
    "passenger_car": VehicleParams(375.0, 45.0, 22e3, 200e3),
    "single_seater": VehicleParams(75.0, 10.0, 30e3, 150e3),
}

# --------------------------------------------------------------------------- road
#: ISO 8608 class means of G_d(n0), m³ (n0 = 0.1 cycles/m).
ISO_CLASSES: dict[str, float] = {c: 16e-6 * 4 ** i for i, c in enumerate("ABCDEFGH")}
#: G_d(n0) of a class relative to its geometric mean: the mean, or the upper limit
#: (classes are a factor 4 wide, centred on the mean in log scale: upper = 2 × mean).
ISO_CLASS_LEVELS: dict[str, float] = {"mean": 1.0, "upper": 2.0}


@dataclass(frozen=True)
class RoadParams:
    """Road input: an ISO 8608 class synthesised at a speed, or a measured profile.

    Attributes
    ----------
    iso_class : str
        'A' … 'H'.
    speed_km_per_h : float
        Vehicle speed, km/h (> 0).
    length_m : float
        Length of synthesised road, m.
    seed : int
        Seed of the random phases.
    profile_csv : str or None
        Measured profile ``distance_m,elevation_m`` (replaces the synthesis).
    iso_class_level : str
        Which G_d(n0) stands for the class: ``"mean"`` (the geometric mean of the
        class, ISO 8608 Table 1: class C = 256e-6 m³; our default) or ``"upper"``
        (the class's upper limit, 2 × mean: class C = 512e-6 m³, as PyPI
        ``roadprofile`` and, by our estimate, Bowen et al. 2019).
    """

    iso_class: str = "C"
    speed_km_per_h: float = _num(100.0, "km/h", "vehicle speed", gt=0.0, le=500.0,
                                 hint="speed is in km/h and must be positive")
    length_m: float = _num(1000.0, "m", "road length", gt=0.0, le=1e6)
    seed: int = 0
    profile_csv: str | None = None
    iso_class_level: str = "mean"

    def __post_init__(self) -> None:
        _validate_numbers(self, "road")
        if self.iso_class_level not in ISO_CLASS_LEVELS:
            raise ParameterError(f"road: iso_class_level '{self.iso_class_level}' unknown; use "
                                 f"one of {', '.join(ISO_CLASS_LEVELS)} (class mean or upper "
                                 f"limit of G_d(n0))")
        cls = str(self.iso_class).upper()
        if cls not in ISO_CLASSES:
            raise ParameterError(f"road: iso_class '{self.iso_class}' is not an ISO 8608 class; "
                                 f"use one of {', '.join(ISO_CLASSES)}")
        object.__setattr__(self, "iso_class", cls)
        if isinstance(self.seed, bool) or not isinstance(self.seed, int):
            raise ParameterError(f"road: seed must be an integer, got {self.seed!r}")
        if self.seed < 0:
            raise ParameterError(f"road: seed = {self.seed} must be a non-negative integer "
                                 f"(numpy's generators take 0 … 2**63); use e.g. seed = 0")

    @property
    def speed_m_per_s(self) -> float:
        return self.speed_km_per_h / 3.6

    @property
    def roughness_m3(self) -> float:
        """G_d(n0) of the class, m³ (class mean, or its upper limit = 2 × mean)."""
        return ISO_CLASSES[self.iso_class] * ISO_CLASS_LEVELS[self.iso_class_level]


# --------------------------------------------------------------------------- loaders
def from_mapping(cls: type, mapping: Mapping[str, Any], where: str) -> Any:
    """Build dataclass ``cls`` from a TOML table, refusing unknown keys.

    Parameters
    ----------
    cls : type
        One of the parameter dataclasses.
    mapping : mapping
        Keys exactly as the field names.
    where : str
        Location used in error messages, e.g. ``"problem.toml [harvester]"``.
    """
    check_keys(mapping, [f.name for f in dataclasses.fields(cls)], where)
    try:
        return cls(**dict(mapping))
    except ParameterError as exc:
        msg = str(exc)
        head = msg.split(":", 1)
        raise ParameterError(f"{where}:{head[1]}" if len(head) == 2 else f"{where}: {msg}") \
            from None


def load_toml(path: str | Path, what: str = "file") -> dict[str, Any]:
    """Read a TOML file with an error that names the file and the line.

    Through the shared limits of every received file (:mod:`ehsa_opt.utils.limits`): its
    size before reading, its encoding (UTF-8; UTF-16 with its byte-order mark decoded;
    another encoding refused naming the byte), and the nesting depth."""
    path = Path(path)
    if not path.is_file():
        raise ParameterError(f"{path}: {what} not found")
    from ..utils.limits import check_nesting, decode_text, nesting_error, read_input_bytes
    try:
        text = decode_text(read_input_bytes(path, what, ParameterError), str(path),
                           ParameterError)
        return check_nesting(tomllib.loads(text), str(path), ParameterError)
    except RecursionError:
        raise nesting_error(str(path), ParameterError) from None
    except tomllib.TOMLDecodeError as exc:
        raise ParameterError(f"{path}: not valid TOML ({exc}); fix the syntax there") from None
    except ParameterError:
        raise
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise ParameterError(f"{path}: not valid TOML ({str(exc)[:120]}); fix the value "
                             f"there") from None
