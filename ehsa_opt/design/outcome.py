"""The outcome of ``ehsa-opt optimize``: ``result.json`` as a frozen record, the solver
results beside it, and what is shown of it (summary lines, figures).

``record`` is exactly the content of ``result.json`` (see :mod:`.optimize` for its keys);
``result`` is the solver result of the chosen method (goal attainment or the NSGA-II
front) and ``goal_attainment_result`` the goal-attainment result whenever it was computed
(also beside an NSGA-II front).  Neither is serialised: an outcome read back with
:meth:`OptimizeOutcome.from_json` has only its record.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..utils.io import atomic_write_text, json_safe
from ..utils.limits import parse_json
from .goal import GoalAttainmentResult
from .nsga2 import ParetoResult

if TYPE_CHECKING:  # plotting is imported only when a figure is drawn
    from matplotlib.figure import Figure

__all__ = ["DESIGN_FIGURES", "DesignResult", "OptimizeOutcome", "motor_summary",
           "time_domain_summary"]

#: The figures of an optimisation and their file names under ``write(out_dir)``.
DESIGN_FIGURES: dict[str, str] = {
    "ga_design": "ga_design_history.png", "ga_mass": "ga_equivalent_mass.png",
    "ga_objectives": "ga_objective_history.png", "pareto": "pareto_projections.png",
    "parallel": "parallel_coordinates.png", "hypervolume": "hypervolume.png"}


@dataclass(frozen=True)
class DesignResult:
    """The result of a design study: ``result.json`` (``record``), the solver results
    (not serialised), the other files' text and the front as named columns.

    Follows pymoo's ``Result``: :attr:`X` (unit-cube designs), :attr:`F` (objectives,
    all minimised: see :attr:`objective_names`), :attr:`G` (constraints, ≤ 0 feasible),
    one row per front design (NSGA-II or another pymoo algorithm) or the one optimum
    (goal attainment); :meth:`table` is the same with names and units, :attr:`design`
    the preferred design.  Nothing is written until :meth:`save`; :meth:`load` reads a
    saved folder back (JSON and CSV).

    Attributes
    ----------
    record : mapping
        ``result.json``'s content (see :mod:`ehsa_opt.design.optimize`).
    result : GoalAttainmentResult or ParetoResult or None
        The chosen method's solver result (None when loaded).
    goal_attainment_result : GoalAttainmentResult or None
        Goal attainment's result whenever it ran (None when loaded).
    files : mapping of str to str
        Text of the other files :meth:`save` writes, by path relative to the folder
        (``pareto.csv``, ``ga_history.json``, ``front_check.csv``, ``motor_<k>/…``).
    front : mapping of str to ndarray or None
        The front (or the optimum) as columns: design variables, objectives, the
        reported quantities (``power_W``, ``efficiency`` …), ``constraint_<name>`` and
        ``feasible``; written as ``front.csv``.
    """

    record: Mapping[str, Any]
    result: GoalAttainmentResult | ParetoResult | None = None
    goal_attainment_result: GoalAttainmentResult | None = None
    files: Mapping[str, str] = field(default_factory=dict)
    front: Mapping[str, Any] | None = None

    # ---------------------------------------------------------------- the record's head
    @property
    def success(self) -> bool:
        return bool(self.record["success"])

    @property
    def message(self) -> str:
        return str(self.record["message"])

    @property
    def method(self) -> str:
        return str(self.record["method"])

    @property
    def design(self) -> dict[str, float]:
        return dict(self.record["design"])

    @property
    def objectives(self) -> dict[str, float]:
        return dict(self.record["objectives"])

    @property
    def metrics(self) -> dict[str, float]:
        return dict(self.record["metrics"])

    @property
    def objective_names(self) -> tuple[str, ...]:
        """The objectives, in the columns of :attr:`F` (all minimised)."""
        return tuple(self.record["objectives"])

    @property
    def constraint_names(self) -> tuple[str, ...]:
        """The constraints, in the columns of :attr:`G`."""
        return tuple(self.record.get("constraint_names")
                     or (self.record.get("motor") or {}).get("constraints", ()))

    def _rows(self) -> Mapping[str, Any]:
        if self.front is not None:
            return self.front
        cols: dict[str, Any] = {k: [v] for k, v in self.design.items()}
        cols.update({k: [v] for k, v in self.objectives.items()})
        cols.update({k: [v] for k, v in self.metrics.items()})
        return cols

    @property
    def X(self) -> Any:
        """Designs in the unit cube of the box, shape (n, n_var)."""
        import numpy as np

        from .problem import DesignSpace
        box = self.record["box"]
        space = DesignSpace(tuple(box), tuple(b["lower"] for b in box.values()),
                            tuple(b["upper"] for b in box.values()),
                            tuple(b["log"] for b in box.values()))
        rows = self._rows()
        return np.atleast_2d(space.to_unit({k: np.asarray(rows[k], float) for k in box}))

    @property
    def F(self) -> Any:
        """Objectives (minimised forms), shape (n, n_obj)."""
        import numpy as np
        rows = self._rows()
        return np.column_stack([np.asarray(rows[k], float) for k in self.objective_names])

    @property
    def G(self) -> Any:
        """Constraints (value / limit − 1, ≤ 0 feasible), shape (n, n_constr); None
        without constraints."""
        import numpy as np
        rows = self._rows()
        names = [c for c in self.constraint_names if f"constraint_{c}" in rows]
        if not names:
            return None
        return np.column_stack([np.asarray(rows[f"constraint_{c}"], float) for c in names])

    def table(self) -> Any:
        """The front (or the optimum) as a tidy table: one row per design, named columns
        with units (``attrs["units"]``); a DataFrame when pandas is installed."""
        from ..utils.tables import tidy_table
        return tidy_table(self._rows(), self.record.get("units"))

    # ---------------------------------------------------------------- saving
    def save(self, out_dir: str | Path) -> list[Path]:
        """Write the study's files into ``out_dir`` (atomically each): ``result.json``,
        ``front.csv`` (:meth:`table`), and :attr:`files`.  Returns the paths written."""
        from ..utils.tables import table_to_csv
        out = Path(out_dir)
        paths = []
        texts = dict(self.files)
        if self.front is not None:
            texts["front.csv"] = table_to_csv(self.front)
        for name, text in texts.items():
            atomic_write_text(out / name, text)
            paths.append(out / name)
        atomic_write_text(out / "result.json", self.to_json())
        return [out / "result.json", *paths]

    @classmethod
    def load(cls, out_dir: str | Path) -> DesignResult:
        """A result read back from a folder :meth:`save` wrote (no solver results)."""
        from ..utils.tables import csv_to_columns
        out = Path(out_dir)
        base = cls.from_json(out / "result.json")
        front = None
        if (out / "front.csv").is_file():
            front = csv_to_columns((out / "front.csv").read_text(encoding="utf-8"),
                                   str(out / "front.csv"))
        files = {}
        for p in sorted(out.rglob("*")):
            rel = p.relative_to(out).as_posix()
            if p.is_file() and p.suffix in (".csv", ".json") and rel not in (
                    "result.json", "front.csv"):
                files[rel] = p.read_text(encoding="utf-8")
        return cls(base.record, files=files, front=front)

    def to_json(self) -> str:
        """``result.json`` text: standard JSON (NaN and infinities as ``null``)."""
        return json.dumps(json_safe(dict(self.record)), indent=2, allow_nan=False)

    @classmethod
    def from_json(cls, source: str | Path) -> DesignResult:
        """An outcome from a ``result.json`` file (a path) or its text; no solver results."""
        where = "result.json"
        if isinstance(source, Path) or not source.lstrip().startswith("{"):
            where = str(source)
            source = Path(source).read_text(encoding="utf-8")
        rec = parse_json(source, where)
        if not isinstance(rec, dict) or not {"method", "design", "objectives"} <= set(rec):
            raise ValueError(f"{where}: not an optimisation result (needs the keys method, "
                             f"design, objectives); write it with `ehsa-opt optimize`")
        return cls(rec)

    # ---------------------------------------------------------------- showing
    def summary(self) -> str:
        """The lines ``ehsa-opt optimize`` prints (warnings: :meth:`warnings`)."""
        from ..vehicle.coverage import out_of_range_lines
        r, m = self.record, self.metrics
        failed = not self.success and not self.message.startswith("stopped after")
        lines = [("FAILED: " if failed else "") + f"{self.method}: {self.message}",
                 "design: " + ", ".join(f"{k} = {v:.4g}" for k, v in self.design.items()),
                 "objectives (minimised): " + ", ".join(f"{k} = {v:.4g}"
                                                        for k, v in self.objectives.items())]
        if "power_W" in m:
            lines.append(f"power {m['power_W']:.1f} W, efficiency {100 * m['efficiency']:.1f} %, "
                         f"W_k rms {m.get('comfort_weighted_rms_m_s2', float('nan')):.3f} m/s^2 "
                         f"(inverse_power = 1 / dimensionless power, inverse_efficiency = "
                         f"1 / efficiency)")
        if "gamma" in r:
            lines.append(f"attainment factor gamma = {r['gamma']:+.4f}")
        if self.method == "nsga2":
            hv = r["hypervolume"]["history"]
            lines.append(f"front: {r['n_front']} designs, hypervolume {hv[-1]['hv']:.4g} after "
                         f"{hv[-1]['n_eval']} evaluations; vs goal attainment: "
                         f"{r.get('front_vs_goal_attainment')}")
        lines += motor_summary(r)
        lines += [line for line, to_err in out_of_range_lines(r.get("out_of_range"))
                  if not to_err]
        if "time_domain_check" in r:
            lines.append(time_domain_summary(r))
        return "\n".join(lines)

    def warnings(self) -> list[str]:
        """Warning lines (the stroke velocity far beyond the friction's identified range)."""
        from ..vehicle.coverage import out_of_range_lines
        return [line for line, to_err in out_of_range_lines(self.record.get("out_of_range"))
                if to_err]

    def figures(self, front_label: str = "NSGA-II") -> dict[str, Figure]:
        """The figures of this outcome, keyed as :data:`DESIGN_FIGURES`: the goal-attainment
        histories (paper Figs 17–19) when goal attainment ran, the front's projections,
        parallel coordinates and hypervolume history for NSGA-II."""
        from ..plots import design as pd
        figs: dict[str, Figure] = {}
        ga = self.goal_attainment_result
        if ga is not None:
            for key, which in (("ga_design", "design"), ("ga_mass", "mass"),
                               ("ga_objectives", "objectives")):
                figs[key] = pd.goal_attainment_history(ga, which)
        res = self.result if self.result is not None else self._front_result()
        if isinstance(res, ParetoResult) and len(res.F):
            ga_rec = self.record.get("goal_attainment")
            ga_pt = ga_rec["objectives"] if ga_rec else None
            marks = self._front_marks(res)
            figs["pareto"] = pd.pareto_projections(
                res, ga_pt, (self.record.get("prototype") or {}).get("objectives"), marks)
            figs["parallel"] = pd.parallel_coordinates(
                res, None if ga_rec is None else {**ga_rec["design"], **ga_pt}, marks=marks)
            figs["hypervolume"] = pd.hypervolume_history({front_label: res.history},
                                                         res.hv_reference)
        return figs

    def _front_result(self) -> ParetoResult | None:
        """The front of a loaded result (:attr:`front`, NSGA-II or another algorithm) as
        a :class:`~.nsga2.ParetoResult`, to draw it; None for goal attainment."""
        import numpy as np
        if self.front is None or self.method != "nsga2":
            return None
        F = self.F
        names = list(self.record["box"])
        rows = self._rows()
        designs = {k: np.asarray(rows[k], float) for k in names}
        chosen = np.array([self.design[k] for k in names])
        pref = int(np.argmin(np.sum((np.column_stack(list(designs.values())) - chosen) ** 2
                                    / np.maximum(chosen ** 2, 1e-300), axis=1)))
        hv = self.record.get("hypervolume", {})
        ref = np.asarray(hv.get("reference_point", [2.0] * F.shape[1]), float)
        return ParetoResult(True, self.message, self.X, designs, F, self.objective_names, pref,
                            str(self.record.get("pick", "knee")), list(hv.get("history", [])),
                            np.ones(F.shape[1]), ref, dict(self.record.get("stats", {})),
                            self.G, str(self.record.get("algorithm", "NSGA2")))

    def plot(self, ax: Any = None) -> Any:
        """The main figure: the front's projections (NSGA-II) or the objectives per
        iteration (goal attainment); returns the figure, writes nothing.  ``ax`` is not
        used (both are multi-panel figures); it is accepted for the common protocol."""
        key = ("pareto" if isinstance(self.result, ParetoResult)
               or (self.result is None and self._front_result() is not None)
               else "ga_objectives")
        figs = self.figures()
        if key not in figs:
            raise ValueError("nothing to plot: a goal-attainment result read from "
                             "result.json has no solver results (iterations); plot the "
                             "result optimize() returned")
        import matplotlib.pyplot as plt
        for k, f in figs.items():
            if k != key:
                plt.close(f)
        return figs[key]

    def _front_marks(self, res: Any) -> dict[str, Any]:
        """What the front figure marks: feasibility, the motor per point, the motor model
        and the pick's active bounds."""
        import numpy as np
        r, front = self.record, self.front or {}
        n = res.F.shape[0]
        marks: dict[str, Any] = {"active_bounds": r.get("active_bounds") or []}
        if r.get("feasible_front") is not None and len(r["feasible_front"]) == n:
            marks["feasible"] = np.asarray(r["feasible_front"], bool)
        for key in ("motor_name", "motor"):  # a selection's names; a catalogue's column
            col = front.get(key)
            if col is not None and len(col) == n and not np.issubdtype(
                    np.asarray(col).dtype, np.number):
                marks["motor"] = [str(m) for m in col]
                break
        mb = r.get("motor") or {}
        marks["motor_label"] = mb.get("chosen") or mb.get("label") or (
            "selected from " + ", ".join(r["front_motors"]) if r.get("front_motors") else
            mb.get("model"))
        return marks

    def write_figures(self, fig_dir: str | Path, names: Mapping[str, str] | None = None,
                      front_label: str = "NSGA-II") -> list[Path]:
        """Write the figures (PNG, atomically) into ``fig_dir``; ``names`` maps a figure key
        to its file name (default :data:`DESIGN_FIGURES`; keys left out of a given mapping
        are not written).  Returns the paths written."""
        import matplotlib.pyplot as plt

        from .. import plots
        names = DESIGN_FIGURES if names is None else names
        paths = []
        for key, fig in self.figures(front_label).items():
            if key in names:
                paths.append(plots.save(fig, Path(fig_dir) / names[key]))
            else:
                plt.close(fig)
        return paths

    def write(self, out_dir: str | Path) -> list[Path]:
        """The optimisation's folder: ``result.json`` and ``figures/`` (as
        :meth:`write_figures`).  Returns the paths written."""
        out = Path(out_dir)
        atomic_write_text(out / "result.json", self.to_json())
        return [out / "result.json", *self.write_figures(out / "figures")]


def motor_summary(outcome: Mapping[str, Any]) -> list[str]:
    """Lines on the motor model, constraint values, active constraints, each violated limit
    with its value and margin, and the variables at a bound of the box (CLI)."""
    lines = []
    if outcome.get("motor"):
        mb = outcome["motor"]
        lines.append(f"motor: {mb.get('label', mb.get('chosen', mb['model']))}"
                     + ("; constraints at the result: " + ", ".join(
                         f"{k} {v:+.3f}" for k, v in outcome["constraints"].items())
                        + f" (active: {', '.join(outcome['active_constraints']) or 'none'})"
                        if outcome.get("constraints") else ""))
    hw = outcome.get("hardware")
    if hw:
        lines.append(f"hardware: {hw['motor']} at k_n {hw['speed_constant_rpm_per_V']:.4g} rpm/V "
                     f"(R_i {hw['internal_resistance_ohm']:.3g} ohm"
                     + (", rewound within its series" if hw.get("rewound") else "") + ")"
                     + (f", screw {hw['screw']} (lead {hw['lead_mm_per_rev']:g} mm)"
                        if "screw" in hw else ""))
    if outcome.get("front_motors"):
        lines.append(f"front motors: {', '.join(outcome['front_motors'])}")
    if outcome.get("constraints") and not outcome.get("feasible", True):
        lines.append("INFEASIBLE: " + ("; ".join(outcome.get("violations") or [])
                                       or "a limit is exceeded"))
    elif "constraints" in outcome and not outcome.get("constraints"):
        lines.append("limits: none checked (no rated limits in this motor model)")
    if outcome.get("active_bounds"):
        lines.append("at a bound of the box: " + ", ".join(outcome["active_bounds"]))
    for row in outcome.get("catalogue", []):
        state = ("feasible" if row["feasible"] else
                 "INFEASIBLE" if row.get("constraints") else "limits not checked")
        lines.append(f"  {row['motor']}: {state}"
                     + (f", gamma {row['gamma']:+.4f}" if row.get("gamma") is not None else "")
                     + (f": {'; '.join(row['violations'])}" if row.get("violations") else
                        f", at or beyond the limit: {', '.join(row['active_constraints'])}"
                        if row["active_constraints"] else ""))
    return lines


def time_domain_summary(outcome: Mapping[str, Any]) -> str:
    """One line on the time-domain re-simulation of the result (CLI)."""
    chk = outcome["time_domain_check"]
    lim = chk.get("rated_limits")
    fr = bool(outcome.get("friction"))
    return (f"time-domain check{' with friction' if fr else ''} ({chk['n_designs']} designs, "
            f"{chk['road']['length_m']:g} m road): worst |error| of the "
            f"{'fast' if fr else 'frequency'} path "
            + ", ".join(f"{k} {100 * v:.2f} %" for k, v in chk["worst_abs_rel_error"].items())
            + ("" if not lim else "; rated limits in the time domain, worst value/limit - 1: "
               + ", ".join(f"{k} {v:+.4f}" for k, v in
                           lim["time_domain_worst_constraint"].items()))
            + f" -> {'within' if chk['within_5pct'] else 'NOT within'} 5 %"
            + _roads_summary(chk.get("held_out_roads"), outcome))


def _roads_summary(roads: Mapping[str, Any] | None, outcome: Mapping[str, Any]) -> str:
    """The held-out roads' part of the time-domain line."""
    if not roads:
        return ""
    hv = (outcome.get("hypervolume") or {}).get("held_out_roads")
    st = roads["settings"]
    return (f"\nheld-out roads (seeds {', '.join(map(str, roads['seeds']))}): "
            f"{roads['n_within']} of {roads['n_designs']} designs within every limit at the "
            f"stated tolerances (time {st['time_fraction']:g}, tyre lift "
            f"{st['tyre_lift_fraction']:g}, peak voltage {st['peak_quantile']:g}); worst "
            "fraction of time beyond: " + ", ".join(
                f"{k} {100 * v:.3g} %" for k, v in roads["worst_fraction"].items())
            + f"; worst rms current / rating {roads['worst_current_over_rating']:.3f}"
            + ("" if "worst_screw_load_over_allowed" not in roads else
               "; worst screw mean load / load of its required life "
               f"{roads['worst_screw_load_over_allowed']:.3f} ({st['screw_life_km']:g} km)")
            + ("" if not hv else f"; hypervolume of the feasible front {hv['mean']:.5g} "
               f"[{hv['interval'][0]:.5g}, {hv['interval'][1]:.5g}] (95 %, "
               f"{hv['n_roads']} roads)"))


#: The former name of :class:`DesignResult`.
OptimizeOutcome = DesignResult
