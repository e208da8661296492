"""Report helpers: how much of a study's result rests on extrapolated friction.

Every vehicle-side table of the report carries a column *beyond the identified range* —
the fraction of the time and of the friction's dissipated energy at stroke velocities
above the bench campaign's peak (:mod:`ehsa_opt.vehicle.coverage`) — and a flag beside the
table when a row exceeds :data:`~ehsa_opt.vehicle.coverage.OUT_OF_RANGE_LIMIT`.  The column
is separate from any other validity flag of the same tables.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

from ..vehicle.coverage import OUT_OF_RANGE_LIMIT

__all__ = ["identified_range", "range_cell", "range_flag", "RANGE_HEADER"]

#: Column header of the tables.
RANGE_HEADER = "beyond identified friction range: time / friction energy"


def identified_range(ctx: Any) -> tuple[float, str]:
    """The identification step's campaign range (m/s) and where it comes from."""
    from ..datasets.friction_source import RANGE_SOURCE_EMBEDDED, embedded_range_m_per_s
    ident = ctx.identification()
    v = ident.identified_range_m_per_s if ident is not None else None
    if v:
        return float(v), "the identified bench campaign"
    return embedded_range_m_per_s(), RANGE_SOURCE_EMBEDDED


def _pct(x: Any) -> str:
    return "–" if x is None or not np.isfinite(float(x)) else f"{100 * float(x):.0f} %"


def range_cell(time_fraction: Any, energy_fraction: Any) -> str:
    """``"45 % / 85 %"`` (energy "–" without friction); a ⚠ above the limit."""
    t = float(time_fraction)
    e = None if energy_fraction is None else float(energy_fraction)
    over = e is not None and np.isfinite(e) and max(t, e) > OUT_OF_RANGE_LIMIT
    return f"{_pct(t)} / {_pct(e)}" + (" ⚠" if over else "")


def range_flag(times: Sequence[Any], energies: Sequence[Any], v_max: float, source: str
               ) -> str:
    """The sentence beside a table: the range, the limit and how many rows exceed it."""
    n = sum(1 for t, e in zip(times, energies)
            if e is not None and np.isfinite(float(e))
            and max(float(t), float(e)) > OUT_OF_RANGE_LIMIT)
    base = (f"Column *{RANGE_HEADER}*: share of the time and of the friction's dissipated "
            f"energy at stroke velocities above {v_max:.2f} m/s, the largest the friction was "
            f"identified at ({source}); above it the friction sets are extrapolations of the "
            f"fitted law (their band widens there).")
    if n:
        return (f"\n\n**⚠ Friction outside its identified range:** {base} {n} row(s) exceed "
                f"the {100 * OUT_OF_RANGE_LIMIT:g} % limit (⚠): their friction effects rest "
                f"mostly on the extrapolation; `ehsa-opt plan-tests` proposes the bench "
                f"tests that would cover them.")
    return f"\n\n{base} No row exceeds the {100 * OUT_OF_RANGE_LIMIT:g} % limit."
