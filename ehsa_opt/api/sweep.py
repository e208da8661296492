"""Design-space studies from a script: :func:`sweep` and :class:`SweepResult`.

A full-factorial grid over harvester/design parameters × speed × road class × vehicle ×
friction case (a problem file's ``[sweep]`` table, and/or the grid given here), evaluated
in parallel into a tidy table; ``save(folder)`` writes ``sweep.csv`` and ``sweep.png``.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Mapping, Sequence

from ..design.sweep import (
    METRIC_COLUMNS,
    SweepSpec,
    parse_sweep,
    rows_to_csv,
    run_sweep,
    sweep_axes,
    sweep_warnings,
)
from ..physics.params import ParameterError, load_toml
from ..utils.log import logger
from ..utils.process import one_blas_thread

__all__ = ["SweepResult", "sweep"]

#: Columns naming a case rather than measuring it.
CASE_COLUMNS = ("vehicle", "iso_class", "speed_km_per_h", "friction")


@dataclass(frozen=True)
class SweepResult:
    """The cases of a sweep, one row each, in grid order.

    Attributes
    ----------
    rows : list of dict
        ``vehicle``, ``iso_class``, ``speed_km_per_h``, ``friction``, the swept design
        parameters, then the metrics (``comfort``, ``comfort_weighted_rms_m_s2``,
        ``road_holding``, ``power_W``, ``efficiency`` …, see
        :data:`ehsa_opt.design.sweep.METRIC_COLUMNS`).
    design_keys : tuple of str
        The swept design parameters.
    seconds : float
        Wall time of the evaluation.
    warnings : list of str
        Road holding beyond 1, friction beyond its identified range.
    """

    rows: list[dict[str, Any]]
    design_keys: tuple[str, ...]
    seconds: float = 0.0
    warnings: tuple[str, ...] = ()

    def table(self) -> Any:
        """The rows as a tidy table (a DataFrame when pandas is installed)."""
        from ..utils.tables import tidy_table
        cols = list(self.rows[0]) if self.rows else []
        return tidy_table({c: [r.get(c) for r in self.rows] for c in cols},
                          {"iso_class": "", "vehicle": "", "friction": ""})

    def summary(self) -> str:
        """Number of cases, what varies and each metric's range (the warnings are in
        :attr:`warnings` and were logged)."""
        varied = [k for k in CASE_COLUMNS + self.design_keys
                  if len({r.get(k) for r in self.rows}) > 1]
        lines = [f"{len(self.rows)} cases in {self.seconds:.2f} s; varied: "
                 f"{', '.join(varied) or 'nothing'}"]
        for c in METRIC_COLUMNS:
            vals = [float(r[c]) for r in self.rows if c in r and r[c] == r[c]]
            if vals:
                lines.append(f"  {c:<40s} {min(vals):.4g} .. {max(vals):.4g}")
        return "\n".join(lines)

    def plot(self, ax: Any = None, x: str | None = None,
             y: Sequence[str] | None = None) -> Any:
        """The metrics ``y`` (default power, efficiency, W_k-weighted acceleration, road
        holding) against ``x`` (default the speed when it varies, else the first design
        parameter), one line per combination of what else varies; returns the figure
        (``ax`` is not used: one panel per metric)."""
        from ..plots.design import sweep_lines
        axes = sweep_axes(self.rows, self.design_keys)
        if axes is None and x is None:
            raise ValueError("nothing to plot: neither the speed nor a design parameter "
                             "varies in this sweep")
        if x is not None:
            if not self.rows or x not in self.rows[0]:
                raise ValueError(f"plot: no column '{x}' (columns: "
                                 f"{', '.join(self.rows[0]) if self.rows else 'none'})")
            hue = [k for k in CASE_COLUMNS + self.design_keys if k != x
                   and len({r.get(k) for r in self.rows}) > 1] or ["vehicle"]
            axes = (x, axes[1] if axes else [], hue)
        assert axes is not None
        ys = list(y) if y is not None else axes[1] or [
            "power_W", "efficiency", "comfort_weighted_rms_m_s2", "road_holding"]
        return sweep_lines(self.rows, axes[0], ys, axes[2])

    def save(self, out_dir: str | Path) -> list[Path]:
        """Write ``sweep.csv`` and, when something varies, ``sweep.png``."""
        from ..utils.io import atomic_write_text
        out = Path(out_dir)
        atomic_write_text(out / "sweep.csv", rows_to_csv(self.rows))
        paths = [out / "sweep.csv"]
        if sweep_axes(self.rows, self.design_keys) is not None:
            from .. import plots
            paths.append(plots.save(self.plot(), out / "sweep.png"))
        return paths

    @classmethod
    def load(cls, out_dir: str | Path) -> SweepResult:
        """Read ``sweep.csv`` back (the folder or the file)."""
        from ..utils.tables import csv_to_columns
        p = Path(out_dir)
        path = p / "sweep.csv" if p.is_dir() else p
        cols = csv_to_columns(path.read_text(encoding="utf-8"), str(path))
        n = len(next(iter(cols.values()))) if cols else 0
        rows = [{k: (v[i].item() if hasattr(v[i], "item") else v[i]) for k, v in cols.items()}
                for i in range(n)]
        skip = set(CASE_COLUMNS) | set(METRIC_COLUMNS)
        return cls(rows, tuple(k for k in cols if k not in skip))


@one_blas_thread
def sweep(problem: str | Path | SweepSpec, *, design: Mapping[str, Sequence[float]] | None = None,
          speed_km_per_h: Sequence[float] | None = None, iso_class: Sequence[str] | None = None,
          vehicle: Sequence[str] | None = None, friction: Sequence[str] | None = None,
          friction_from: str | None = None, jobs: int = 1, scheduler: Any = None
          ) -> SweepResult:
    """Evaluate a design-space study; nothing written.

    Parameters
    ----------
    problem : path or SweepSpec
        A problem file (its ``[sweep]`` table, if any, and its ``[harvester]`` as the
        base design, ``[road]`` for length and seed), a shipped problem's name, or a
        ready :class:`~ehsa_opt.design.sweep.SweepSpec`.
    design : mapping, optional
        Swept parameters and their values, e.g. ``{"lead_mm_per_rev": [5, 10, 20]}``
        (any :class:`~ehsa_opt.physics.params.HarvesterParams` field,
        ``total_inertia_gcm2``, ``speed_constant_rpm_per_V``); replaces
        ``[sweep.design]``.
    speed_km_per_h, iso_class, vehicle, friction : sequences, optional
        Replace the ``[sweep]`` lists (friction cases ``none``, ``min``, ``best``,
        ``max``).
    friction_from : str, optional
        An ``identification.json`` whose friction sets the cases use.
    jobs : int
        Local worker processes.
    scheduler : str or distributed.Client, optional
        A Dask cluster instead of local processes (same numbers).

    Returns
    -------
    SweepResult
    """
    if friction_from is not None:
        from ..datasets.friction_source import parse_friction_spec
        if str(parse_friction_spec(friction_from)[0]) != str(friction_from):
            raise ParameterError(
                f"sweep --friction {friction_from}: give the file only; the cases come from "
                f"[sweep] friction = [\"none\", \"min\", \"best\", \"max\"]")
    if isinstance(problem, SweepSpec):
        if any(v is not None for v in (design, speed_km_per_h, iso_class, vehicle, friction,
                                       friction_from)):
            raise ParameterError("sweep: give the grid in the SweepSpec or in the keywords, "
                                 "not both")
        spec = problem
    else:
        from ..datasets.problem_file import resolve_problem_path
        path = resolve_problem_path(problem)
        doc = dict(load_toml(path))
        table = dict(doc.get("sweep", {}))
        for key, value in (("design", design), ("speed_km_per_h", speed_km_per_h),
                           ("iso_class", iso_class), ("vehicle", vehicle),
                           ("friction", friction)):
            if value is not None:
                table[key] = ({k: list(v) for k, v in value.items()} if key == "design"
                              else list(value))
        if table or "sweep" in doc:  # without either parse_sweep says what to add
            doc["sweep"] = table
        where = str(problem) if Path(problem).is_file() else str(path)
        spec = parse_sweep(doc, where, friction_from=friction_from)
    logger.info("sweep: %d cases", spec.n_cases)
    t0 = time.perf_counter()
    rows = run_sweep(spec, jobs=jobs, scheduler=scheduler)
    notes = tuple(sweep_warnings(rows, spec))
    for line in notes:
        logger.warning("%s", line)
    return SweepResult(rows, tuple(k for k, _ in spec.design), time.perf_counter() - t0, notes)
