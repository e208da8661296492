"""A design evaluator extended with the user's own objectives and constraints.

:meth:`ehsa_opt.design.problem.DesignProblem.with_objective` and
:meth:`~ehsa_opt.design.problem.DesignProblem.with_constraint` wrap the problem's
evaluator in an :class:`ExtendedObjectives`: it calls the wrapped evaluator, then each
user function on the outputs (every evaluator output — objectives, ``power_W``,
``current_rms_A``, ``stroke_rms_m`` … — and the design variables, as arrays over the
designs), and appends the results as objectives (minimised) or as constraints
(``(value − upper) / |upper| ≤ 0`` feasible: ``value / upper − 1`` for a positive limit,
the convention of the built-in rated limits).

Every other attribute (``base``, ``motor``, ``frictions``, ``design_mapping`` …) is the
wrapped evaluator's, so the study's checks (time-domain re-simulation, validity) see the
same physics.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Mapping

import numpy as np

from ..physics.params import ParameterError

__all__ = ["UserQuantity", "ExtendedObjectives"]


@dataclass(frozen=True)
class UserQuantity:
    """One user objective or constraint.

    Attributes
    ----------
    name : str
        Column name (with its unit, e.g. ``peak_current_A``).
    func : callable
        ``func(outputs) -> array``: ``outputs`` maps every evaluator output and design
        variable to an array over the designs.
    unit : str
        Unit of ``func``'s value (``"-"`` if dimensionless); shown in tables.
    upper : float or None
        For a constraint, the upper limit of ``func`` (same unit); None for an objective.
    """

    name: str
    func: Callable[[Mapping[str, np.ndarray]], Any]
    unit: str = "-"
    upper: float | None = None


class ExtendedObjectives:
    """An evaluator plus user objectives and constraints (see the module text)."""

    def __init__(self, inner: Any, objectives: tuple[UserQuantity, ...] = (),
                 constraints: tuple[UserQuantity, ...] = ()) -> None:
        self.inner = inner
        self.objectives = objectives
        self.user_constraints = constraints
        taken = set(inner.objective_names) | set(getattr(inner, "constraint_names", ()))
        for q in objectives + constraints:
            if not q.name.isidentifier():
                raise ParameterError(f"objective/constraint name {q.name!r}: use letters, "
                                     f"digits and '_' (a column name, e.g. peak_current_A)")
            if q.name in taken:
                raise ParameterError(f"objective/constraint '{q.name}' exists already; "
                                     f"choose another name")
            taken.add(q.name)
        for q in constraints:
            if q.upper is None or not np.isfinite(q.upper) or q.upper == 0:
                raise ParameterError(f"constraint '{q.name}': give a finite, non-zero upper "
                                     f"limit, got {q.upper!r}")

    @property
    def objective_names(self) -> tuple[str, ...]:
        return tuple(self.inner.objective_names) + tuple(q.name for q in self.objectives)

    @property
    def constraint_names(self) -> tuple[str, ...]:
        return tuple(getattr(self.inner, "constraint_names", ())) + tuple(
            q.name for q in self.user_constraints)

    def __getattr__(self, name: str) -> Any:
        if name == "inner":  # not yet set (unpickling)
            raise AttributeError(name)
        return getattr(self.inner, name)

    def __call__(self, design: Mapping[str, Any]) -> dict[str, np.ndarray]:
        out = dict(self.inner(design))
        seen = {**{k: np.asarray(v, float) for k, v in design.items()}, **out}
        shape = np.shape(next(iter(out.values())))
        for q in self.objectives:
            out[q.name] = self._value(q, seen, shape)
        for q in self.user_constraints:
            v = self._value(q, seen, shape)
            out[q.name] = v
            out[f"constraint_{q.name}"] = (v - float(q.upper)) / abs(float(q.upper))
        return out

    @staticmethod
    def _value(q: UserQuantity, outputs: Mapping[str, np.ndarray], shape: tuple) -> np.ndarray:
        try:
            v = np.asarray(q.func(outputs), dtype=float)
        except KeyError as exc:
            raise ParameterError(f"'{q.name}': the function asked for {exc}, which the "
                                 f"evaluator does not give (available: "
                                 f"{', '.join(sorted(outputs))})") from None
        return np.broadcast_to(v, shape).copy()

    def fingerprint(self) -> dict[str, Any]:
        inner = self.inner.fingerprint() if hasattr(self.inner, "fingerprint") else repr(
            self.inner)
        return {"inner": inner,
                "objectives": [(q.name, q.unit, getattr(q.func, "__qualname__", ""))
                               for q in self.objectives],
                "constraints": [(q.name, q.unit, q.upper, getattr(q.func, "__qualname__", ""))
                                for q in self.user_constraints]}
