"""The base parameters of the bench model, each declared once (as lmfit's ``Parameter``).

A :class:`Parameter` carries its unit, its physical bounds (what any value must satisfy:
:class:`~ehsa_opt.physics.params.FrictionParams` validates against them), the range
multistarts draw from, the scale decision variables are divided by and a typical value.
:data:`PARAMETERS` declares the eight friction parameters, the two of the LuGre (presliding)
nut friction (used by models with a dynamic ``friction_law``), the exponent of the
generalised Stribeck curve (``friction_law="lugre_stribeck"``) and the two rig terms of a rig
without generator (moving mass, force offset).

A procedure that needs narrower (or other) limits does not keep a table of its own: it
names an override of the one declaration, with the reason, through
:meth:`Parameter.with_bounds` or :func:`override` (e.g. the identification's bounds in
:data:`ehsa_opt.estimation.identify_options.IDENTIFY_PARAMETERS`, the discrepancy fit's
in :data:`ehsa_opt.estimation.discrepancy.rig.DISCREPANCY_PARAMETERS`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass


__all__ = ["Parameter", "PARAMETERS", "override"]


@dataclass(frozen=True)
class Parameter:
    """One base parameter: unit, physical bounds, start range, scale.

    Attributes
    ----------
    name : str
        The name, with its unit (``nut_breakaway_N``).
    unit : str
        The unit, as printed (``"N"``, ``"N s/m"``).
    doc : str
        What it is, in a few words.
    lower, upper : float
        Bounds, in ``unit``.  In :data:`PARAMETERS` the physical bounds; in an override
        the procedure's.
    start : tuple of float
        (low, high) of the uniform draws of a multistart, in ``unit`` (an assumption:
        the distributor ranges of small ball screws and generator bearings).
    scale : float
        Typical magnitude the identification divides the decision variable by.
    typical : float
        A typical value (the prototype's order of magnitude): the default of a parameter
        neither fitted nor given in the discrepancy fit, and its scale there.
    lower_open : bool
        The lower bound itself is not admissible (``value > lower``; velocities).
    hint : str
        A fix-it hint added to a validation message.
    procedure, why : str
        Empty in :data:`PARAMETERS`; for an override, the procedure it belongs to and why
        it differs from the declaration.
    """

    name: str
    unit: str
    doc: str
    lower: float
    upper: float
    start: tuple[float, float]
    scale: float
    typical: float
    lower_open: bool = False
    hint: str = ""
    procedure: str = ""
    why: str = ""

    def __post_init__(self) -> None:
        lo, hi = self.start
        finite = math.isfinite(self.lower) and math.isfinite(self.upper)
        if not (finite and self.lower < self.upper):
            raise ValueError(f"parameter {self.name}: bounds [{self.lower}, {self.upper}] must be "
                             f"finite with lower < upper")
        if not (lo <= hi and self.scale > 0):
            raise ValueError(f"parameter {self.name}: start range {self.start} must have low <= "
                             f"high and scale {self.scale} must be > 0")

    @property
    def bounds(self) -> tuple[float, float]:
        """(lower, upper) in ``unit``."""
        return (self.lower, self.upper)

    def with_bounds(self, lower: float, upper: float, *, procedure: str, why: str,
                    scale: float | None = None) -> "Parameter":
        """The same parameter with a procedure's bounds (and scale); ``procedure`` and
        ``why`` name the override."""
        if not (procedure and why):
            raise ValueError(f"parameter {self.name}: an override names its procedure and why")
        return dataclasses.replace(self, lower=float(lower), upper=float(upper),
                                   scale=self.scale if scale is None else float(scale),
                                   procedure=procedure, why=why)


def _p(name: str, unit: str, doc: str, bounds: tuple[float, float], start: tuple[float, float],
       scale: float, typical: float, **kw: object) -> Parameter:
    return Parameter(name, unit, doc, bounds[0], bounds[1], start, scale, typical, **kw)


#: The declaration: physical bounds (those :class:`~ehsa_opt.physics.params.FrictionParams`
#: validates), the multistart's start ranges and the scales.
PARAMETERS: dict[str, Parameter] = {p.name: p for p in (
    _p("nut_breakaway_N", "N", "nut-screw breakaway force F_brk", (0.0, 1e5), (10.0, 200.0),
       100.0, 50.0),
    _p("nut_coulomb_N", "N", "nut-screw Coulomb force F_C", (0.0, 1e5), (5.0, 150.0),
       100.0, 30.0),
    _p("nut_breakaway_velocity_m_per_s", "m/s", "nut-screw breakaway velocity Vel_fbs",
       (0.0, 10.0), (1e-3, 5e-2), 0.01, 0.01, lower_open=True,
       hint="velocity is in m/s, e.g. 0.01"),
    _p("nut_viscous_Ns_per_m", "N s/m", "nut-screw viscous coefficient f_v", (0.0, 1e6),
       (10.0, 500.0), 100.0, 150.0),
    _p("bearing_breakaway_Nm", "N m", "bearing breakaway torque T_brk", (0.0, 100.0),
       (1e-3, 5e-2), 0.01, 0.02),
    _p("bearing_coulomb_Nm", "N m", "bearing Coulomb torque T_C", (0.0, 100.0), (1e-3, 5e-2),
       0.01, 0.015),
    _p("bearing_breakaway_velocity_rad_per_s", "rad/s", "bearing breakaway velocity Vel_fsm",
       (0.0, 1e4), (0.1, 5.0), 1.0, 1.0, lower_open=True),
    _p("bearing_viscous_Nms_per_rad", "N m s/rad", "bearing viscous coefficient t_v",
       (0.0, 10.0), (1e-6, 1e-4), 1e-5, 3e-5),
    _p("presliding_stiffness_N_per_m", "N/m", "bristle stiffness sigma_0 of the LuGre friction",
       (0.0, 1e10), (3e5, 1e7), 1e6, 1e6, lower_open=True,
       hint="a ball screw's presliding stiffness is 1e5-1e8 N/m"),
    _p("presliding_damping_Ns_per_m", "N s/m", "bristle damping sigma_1 of the LuGre friction",
       (0.0, 1e6), (0.0, 3000.0), 1000.0, 500.0),
    _p("stribeck_exponent", "1", "exponent delta of the generalised Stribeck curve "
       "exp(-|v/v_S|^delta) (friction_law='lugre_stribeck')", (0.1, 10.0), (0.5, 2.0), 1.0,
       1.0, hint="reported between 0.5 and 2 (Armstrong-Helouvry et al. 1994)"),
    _p("inertia_kg", "kg", "moving mass M", (0.0, 1e4), (10.0, 200.0), 100.0, 50.0),
    _p("offset_N", "N", "force offset", (-1e4, 1e4), (-20.0, 20.0), 10.0, 0.0),
)}


def override(procedure: str, why: str, bounds: Mapping[str, tuple[float, float]],
             scales: Mapping[str, float] | None = None,
             base: Mapping[str, Parameter] | None = None) -> dict[str, Parameter]:
    """Every parameter of ``base`` (default :data:`PARAMETERS`), those in ``bounds`` with the
    procedure's bounds (and ``scales``): a named override table.

    >>> ident = override("identification", "distributor upper ends",
    ...                  {"nut_breakaway_N": (0.0, 200.0)})
    >>> ident["nut_breakaway_N"].bounds, ident["nut_coulomb_N"].bounds
    ((0.0, 200.0), (0.0, 100000.0))
    """
    base = PARAMETERS if base is None else base
    unknown = [n for n in (*bounds, *(scales or {})) if n not in base]
    if unknown:
        raise KeyError(f"override {procedure!r}: unknown parameter(s) {', '.join(unknown)} "
                       f"(declared: {', '.join(base)})")
    scales = scales or {}
    out = dict(base)
    for n, (lo, hi) in bounds.items():
        out[n] = base[n].with_bounds(lo, hi, procedure=procedure, why=why, scale=scales.get(n))
    for n, s in scales.items():
        if n not in bounds:
            out[n] = base[n].with_bounds(*base[n].bounds, procedure=procedure, why=why, scale=s)
    return out
