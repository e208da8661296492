"""Result types of the identification (:mod:`ehsa_opt.estimation.identify`): simulated
signals (:class:`Prediction`) and the whole procedure's report
(:class:`IdentificationReport`, of one :class:`~ehsa_opt.estimation.fit_result.FitResult`
per test), plus the Eq 5 metrics."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from ..datasets.bench_format import BenchData, BenchDataError, BenchTest, load_bench
from ..physics.friction import rod_friction_N
from ..physics.params import FRICTION_NAMES, ParameterError
from ..utils.io import json_safe
from .fit_result import FitResult
from .test_simulation import Prediction, simulate_tests
from .test_velocity import test_peak_velocity_m_per_s

if TYPE_CHECKING:
    from matplotlib.figure import Figure

__all__ = ["Prediction", "IdentificationReport", "eq5_delta",
           "force_relative_error_percent", "test_errors", "summarise_identifiability"]

_BEARING = FRICTION_NAMES[4:]
#: FitResult fields stored per test beyond the table's columns, so a report reloads whole.
_RELOAD = ("free", "objective", "seconds", "per_test", "history", "identifiability")
#: The joint fit's fields stored beside its table.
_JOINT_RELOAD = ("status", "message", "free", "objective", "nit", "seconds", "path")


def eq5_delta(simulated: Any, measured: Any) -> float:
    """Paper Eq 5 as printed: δ = sqrt( (1/N) Σ |(S_s − S_e) / max|S_e|| )."""
    s, m = np.asarray(simulated, float), np.asarray(measured, float)
    if s.shape != m.shape or s.size == 0:
        raise ValueError(f"eq5_delta: shapes differ or empty ({s.shape} vs {m.shape})")
    return float(np.sqrt(np.mean(np.abs((s - m) / np.max(np.abs(m))))))


def force_relative_error_percent(simulated: Any, measured: Any) -> float:
    """‖F_s − F_e‖₂ / ‖F_e‖₂ in % (the EMPS reference's figure of merit)."""
    s, m = np.asarray(simulated, float), np.asarray(measured, float)
    if s.shape != m.shape or s.size == 0:
        raise ValueError(f"force_relative_error_percent: shapes differ ({s.shape} vs {m.shape})")
    return float(100.0 * np.linalg.norm(s - m) / np.linalg.norm(m))


# ====================================================================== results
@dataclass
class IdentificationReport:
    """Result of :func:`identify`: per-test fits, bounds, identifiability, joint fit.

    Attributes
    ----------
    data : BenchData
    fits : list[FitResult]
        One per test (paper procedure).
    bounds : dict[str, list[float]]
        Min and max of each parameter over the successful per-test fits (Table 2).
    joint : FitResult or None
        One parameter set for the training tests.
    holdout_files : list[str]
    holdout_errors : list[dict]
        Eq 5 and relative error of the joint fit on the held-out tests.
    identifiable : dict
        Summary of the identifiability analysis (see :meth:`to_json`).
    seconds : float
    starts : int
        Multistart points per test.
    friction_law : str
        The friction law of the fits (``"static"`` or ``"lugre"``).
    """

    data: BenchData
    fits: list[FitResult]
    bounds: dict[str, list[float]]
    joint: FitResult | None
    holdout_files: list[str]
    holdout_errors: list[dict]
    identifiable: dict
    seconds: float = 0.0
    starts: int = 0
    friction_law: str = "static"

    @property
    def success(self) -> bool:
        return any(f.success for f in self.fits)

    def to_dict(self) -> dict:
        """The file ``ehsa-opt identify`` writes, as standard-JSON types:
        ``{"tests": [...], "bounds": {...}, "identifiable": {...}, "joint_fit": ...}``
        (every key: the formats page); :meth:`from_dict` reloads it."""
        tests = []
        gen = self.data.has_generator
        for t, f in zip(self.data.tests, self.fits):
            params = {k: v for k, v in f.parameters.items()
                      if gen or k not in _BEARING}
            tests.append({"file": t.file, "frequency_hz": t.frequency_hz, "load_ohm": t.load_ohm,
                          "parameters": params if f.success else None,
                          "delta_F": f.delta_F, "delta_V": f.delta_V,
                          "force_relative_error_percent": f.force_relative_error_percent,
                          "success": f.success, "status": f.status, "message": f.message,
                          "nit": f.nit, "starts": f.starts, "path": f.path,
                          **{k: getattr(f, k) for k in _RELOAD}})
        joint = None
        if self.joint is not None:
            j = self.joint
            joint = {"success": j.success, "parameters": j.parameters,
                     "train_files": [r["file"] for r in j.per_test],
                     "train": j.per_test, "holdout": self.holdout_errors,
                     "holdout_files": list(self.holdout_files),
                     **{k: getattr(j, k) for k in _JOINT_RELOAD}}
        # absolute: the file is read from other folders (plan-tests resolves a relative
        # data_dir against the file's own folder)
        data_dir = str(Path(self.data.path).resolve()) if self.data.path else ""
        return json_safe({"data_dir": data_dir, "rig": self.data.rig_name,
                          "has_generator": gen, "tests": tests, "bounds": self.bounds,
                          "identifiable": self.identifiable, "joint_fit": joint,
                          "seconds": self.seconds, "starts_per_test": self.starts,
                          "friction_law": self.friction_law})

    def to_json(self) -> str:
        """:meth:`to_dict` as JSON text (reloaded by :meth:`from_json`)."""
        return json.dumps(self.to_dict(), indent=1, allow_nan=False)

    @classmethod
    def from_dict(cls, doc: Mapping[str, Any], data: BenchData | None = None,
                  where: str = "identification result") -> "IdentificationReport":
        """Reload a report from :meth:`to_dict` (or an identification.json) to inspect or
        plot it.  ``data``: the bench data it was identified on (default: loaded from
        the file's ``data_dir``); its tests must be the file's ``tests[].file``.

        The document is validated as received data first
        (:func:`~ehsa_opt.datasets.identification_file.check_identification`); a bad one
        raises :class:`~ehsa_opt.physics.params.ParameterError` (or
        :class:`~ehsa_opt.datasets.bench_format.BenchDataError` for the bench data)
        naming ``where``, the key and the fix."""
        from ..datasets.identification_file import RERUN, check_identification
        doc = check_identification(doc, where)
        for key in ("data_dir", "tests", "bounds", "identifiable"):
            if key not in doc:
                raise BenchDataError(f"{where}: no key '{key}'; it was not "
                                     f"written by IdentificationReport.to_json / ehsa-opt "
                                     f"identify")
        if data is None:
            data = load_bench(doc["data_dir"])
        files = [t["file"] for t in doc["tests"]]
        if [t.file for t in data.tests] != files:
            raise BenchDataError(f"{where}: its tests {files} are not the tests "
                                 f"of {data.path} ({[t.file for t in data.tests]}); pass the "
                                 f"bench data it was identified on as data=")
        try:
            return cls._build(doc, data)
        except (KeyError, TypeError, AttributeError, IndexError, ValueError) as exc:
            raise ParameterError(f"{where}: a table does not hold what the report needs "
                                 f"({type(exc).__name__}: {str(exc)[:200]}); {RERUN}") from None

    @classmethod
    def _build(cls, doc: Mapping[str, Any], data: BenchData) -> "IdentificationReport":
        fits = [_fit_of(t) for t in doc["tests"]]
        j = doc.get("joint_fit")
        joint = None if j is None else FitResult(
            success=bool(j["success"]), parameters=_floats(j.get("parameters")),
            per_test=list(j.get("train", [])),
            **{"message": "", **{k: j[k] for k in _JOINT_RELOAD if j.get(k) is not None}})
        held = list(j.get("holdout", [])) if j is not None else []
        return cls(data, fits, {k: [float(x) for x in v] for k, v in doc["bounds"].items()},
                   joint, list(j.get("holdout_files", [r.get("file") for r in held]))
                   if j is not None else [], held, dict(doc["identifiable"]),
                   float(doc.get("seconds") or 0.0), int(doc.get("starts_per_test") or 0),
                   str(doc.get("friction_law") or "static"))

    @classmethod
    def from_json(cls, text: str | bytes, data: BenchData | None = None,
                  where: str = "identification result") -> "IdentificationReport":
        """Reload a report written by :meth:`to_json` (see :meth:`from_dict`): through the
        shared JSON limits (nesting, standard constants; bytes in UTF-8 or UTF-16)."""
        from ..utils.limits import parse_json
        return cls.from_dict(parse_json(text, where, ParameterError), data, where)

    def summary(self, json_path: str | Path = "identification.json") -> str:
        """The lines ``ehsa-opt identify`` prints: tests converged, per-test Eq 5 δ and
        force error (or why a test failed), the rig terms of a rig without generator."""
        ok = sum(f.success for f in self.fits)
        lines = [f"identified {ok}/{len(self.fits)} tests in {self.seconds:.1f} s "
                 f"({self.starts} starts each); results in {json_path}"]
        for t, f in zip(self.data.tests, self.fits):
            if f.success:
                dv = f"{f.delta_V:.4f}" if f.delta_V is not None else "—"
                lines.append(f"  {t.file}: δ_F {f.delta_F:.4f}  δ_V {dv}  force error "
                             f"{f.force_relative_error_percent:.2f} %  ({f.status})")
            else:
                lines.append(f"  {t.file}: FAILED ({f.message})")
        if not self.data.has_generator and self.fits and self.fits[0].success:
            p = self.fits[0].parameters
            lines.append(f"  M = {p['inertia_kg']:.2f} kg, F_v = {p['nut_viscous_Ns_per_m']:.1f} "
                         f"N s/m, F_C = {p['nut_coulomb_N']:.2f} N, offset = "
                         f"{p['offset_N']:.2f} N")
        return "\n".join(lines)

    def figures(self) -> dict[str, Figure]:
        """Figs 8–12, the identifiability picture and the joint fit on a held-out test,
        keyed by file name; the model's signals they show are simulated here."""
        from ..datasets.embedded import load_truth
        from ..plots import identify as P
        good = [k for k, f in enumerate(self.fits) if f.success]
        if not good:
            return {}
        k = good[len(good) // 2]  # representative test: the middle one of the matrix
        sim = {"has_generator": self.data.has_generator, "friction_law": self.friction_law}
        pred = simulate_tests([self.data.tests[k]], self.data.harvester,
                              self.fits[k].parameters, **sim)[0]
        held = None
        if self.joint is not None and self.joint.success and self.holdout_files:
            tests = [x for x in self.data.tests if x.file == self.holdout_files[0]]
            held = simulate_tests(tests, self.data.harvester, self.joint.parameters, **sim)[0]
        truth = None
        if len(good) >= 2 and getattr(self.data, "path", None):
            truth = (load_truth(self.data.path) or {}).get("friction")
        peaks = [test_peak_velocity_m_per_s(t) for t in self.data.tests]
        return P.report_figures(self, k, pred, peaks, held, truth)

    def plot(self, ax: Any = None) -> list[Figure]:
        """The figures of :meth:`figures` (a list; nothing written).  ``ax`` is not used
        (several figures); it is accepted for the common protocol."""
        return list(self.figures().values())

    def write(self, out_dir: str | Path) -> list[Path]:
        """Write the figures of :meth:`figures` to ``out_dir`` (PNG, atomically)."""
        from .. import plots
        return [plots.save(fig, Path(out_dir) / name) for name, fig in self.figures().items()]


def _floats(d: Mapping[str, Any] | None) -> dict[str, float]:
    return {k: (math.nan if v is None else float(v)) for k, v in (d or {}).items()}


def _fit_of(t: Mapping[str, Any]) -> FitResult:
    """One test's :class:`FitResult` from its ``tests[]`` entry."""
    extra = {k: t[k] for k in _RELOAD if t.get(k) is not None}
    if "objective" in extra:
        extra["objective"] = float(extra["objective"])
    return FitResult(success=bool(t["success"]), message=t.get("message", ""),
                     status=t.get("status", ""), parameters=_floats(t.get("parameters")),
                     nit=int(t.get("nit") or 0), starts=list(t.get("starts", [])),
                     delta_F=t.get("delta_F"), delta_V=t.get("delta_V"),
                     force_relative_error_percent=t.get("force_relative_error_percent"),
                     path=t.get("path", "collocation"), **extra)


def test_errors(tests: Sequence[BenchTest], preds: Sequence[Prediction],
                resolved: Sequence[np.ndarray] | None = None) -> list[dict]:
    """Eq 5 δ_F, δ_V and the force relative error of each test on its full grid, or on
    its ``resolved`` samples (recorded tests: outside the windows around corners that
    the motion's derivatives do not resolve; ``resolved_percent`` says how many)."""
    rows = []
    for k, (t, pr) in enumerate(zip(tests, preds)):
        m = (np.asarray(resolved[k], bool) if resolved is not None
             else np.ones(t.n_samples, bool))
        rows.append({"file": t.file,
                     "delta_F": eq5_delta(pr.force_N[m], t.force_N[m]),
                     "delta_V": (eq5_delta(pr.voltage_V[m], t.voltage_V[m])
                                 if pr.voltage_V is not None else None),
                     "force_relative_error_percent": force_relative_error_percent(
                         pr.force_N[m], t.force_N[m]),
                     "resolved_percent": 100.0 * float(m.mean())})
    return rows



def summarise_identifiability(data: BenchData, fits: Sequence[FitResult]) -> dict:
    """Across tests: which directions are weak, spread of raw parameters against the
    spread of the identifiable rod friction, and the rigid-bench voltage finding."""
    good = [(t, f) for t, f in zip(data.tests, fits) if f.success and f.identifiability]
    if not good:
        return {"note": "no successful fit to analyse"}
    weak_counts: dict[str, int] = {}
    for _, f in good:
        seen = set()
        for d in f.identifiability["directions"]:
            if not d["identifiable"]:
                seen.add(" / ".join(sorted(d["main"])))
        for s in sorted(seen):  # a set's order changes with the hash seed
            weak_counts[s] = weak_counts.get(s, 0) + 1
    r = data.harvester.lead_m_per_rad
    spread = {}
    for n in good[0][1].free:
        vals = np.array([f.parameters[n] for _, f in good])
        spread[n] = float(np.std(vals) / max(abs(np.mean(vals)), 1e-300))
    rod_spread = {}
    if "nut_coulomb_N" in good[0][1].free:
        for v in (0.02, 0.05, 0.1):
            vals = np.array([float(rod_friction_N(v, [f.parameters[n] for n in FRICTION_NAMES],
                                                  r)) for _, f in good])
            rod_spread[f"{v:g}"] = {"mean_N": float(vals.mean()),
                                    "relative_spread": float(vals.std() / abs(vals.mean()))}
    per_test = [{"file": t.file, "condition_number": f.identifiability["condition_number"],
                 "non_identifiable": f.identifiability["non_identifiable"],
                 "combinations": f.identifiability["combinations"]} for t, f in good]
    voltage_note = None
    if data.has_generator:
        voltage_note = ("On a rigid bench the winding current obeys L di/dt = K_e v/r − R i "
                        "with v prescribed: δ_V does not depend on any friction parameter. "
                        "Where δ_V > δ_F the minimax max(δ_V, δ_F) is flat in the friction; "
                        "the identification minimises t + w·mean(J) so that the force error "
                        "still decides the friction.")
    return {"non_identifiable_directions": weak_counts, "relative_spread_of_parameters": spread,
            "rod_friction_spread_by_velocity_m_per_s": rod_spread, "per_test": per_test,
            "voltage_independent_of_friction": voltage_note}
