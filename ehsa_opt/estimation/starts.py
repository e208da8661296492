"""Start points of a multistart, one concept for every fit.

``starts`` is either an integer — that many points drawn (seeded) in the declared start
ranges (:data:`~ehsa_opt.physics.base_parameters.PARAMETERS`; a component's parameters at
their defaults for the first point and drawn in their ``ParamSpec`` bounds for the others)
— or a list of start points (name → value), each kept as given.  Both
:func:`~ehsa_opt.estimation.identify.fit_tests` and
:func:`~ehsa_opt.estimation.discrepancy.fit.fit_group` take it.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Union

import numpy as np

from ..physics.bench_model import BenchModel
from ..physics.base_parameters import PARAMETERS

__all__ = ["Starts", "draw_start", "draw_starts"]

#: A number of drawn start points, or the start points themselves.
Starts = Union[int, Sequence[Mapping[str, float]]]

#: Breakaway ≥ Coulomb: a drawn pair in the wrong order is swapped.
_TIES = {"nut_breakaway_N": "nut_coulomb_N", "bearing_breakaway_Nm": "bearing_coulomb_Nm"}


def draw_start(model: BenchModel, free: Sequence[str], rng: np.random.Generator,
               k: int) -> dict[str, float]:
    """Start ``k``: base parameters uniform in their declared start ranges, components at
    their defaults for k = 0 and drawn in their bounds otherwise (log-uniform when the
    bounds span more than two decades)."""
    out = {}
    for n in free:
        if n in PARAMETERS:
            lo, hi = PARAMETERS[n].start
            out[n] = float(rng.uniform(lo, hi))
        else:
            q = model.param_specs[n]
            if k == 0:
                out[n] = q.default
            elif q.lower > 0 and q.upper / q.lower > 100:
                out[n] = float(np.exp(rng.uniform(np.log(q.lower), np.log(q.upper))))
            else:
                out[n] = float(rng.uniform(q.lower, q.upper))
    for brk, coul in _TIES.items():
        if brk in out and coul in out and out[brk] < out[coul]:
            out[brk], out[coul] = out[coul], out[brk]
    return out


def draw_starts(model: BenchModel, free: Sequence[str], starts: Starts, seed: int = 0,
                where: str = "fit") -> list[dict[str, float]]:
    """The start points of ``starts`` (see the module docstring) for the ``free`` names.

    Raises
    ------
    ValueError
        ``starts`` is neither an integer >= 1 nor a non-empty list of mappings (``where``
        names the caller in the message).
    """
    if isinstance(starts, (bool, np.bool_)):
        raise ValueError(f"{where}: starts must be an integer >= 1 or a list of start "
                         f"points, got {starts!r}")
    if isinstance(starts, (int, np.integer)):
        if starts < 1:
            raise ValueError(f"{where}: starts must be an integer >= 1, got {starts!r}")
        rng = np.random.default_rng(seed)
        return [draw_start(model, free, rng, k) for k in range(int(starts))]
    points = list(starts) if isinstance(starts, Sequence) and not isinstance(starts, str) else []
    if not points or not all(isinstance(s, Mapping) for s in points):
        raise ValueError(f"{where}: starts must be an integer >= 1 or a non-empty list of "
                         f"start points (name -> value), got {starts!r}")
    return [{n: float(v) for n, v in s.items()} for s in points]
