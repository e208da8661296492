"""Friction identification from a script: :func:`identify` and
:class:`IdentificationResult`.

The paper's procedure on a bench data directory (per-test multistart fits, Table 2
bounds, identifiability, a joint fit judged on held-out tests, the data-supported
friction sets) with the result in memory; ``save(folder)`` writes
``identification.json`` and the figures, :meth:`IdentificationResult.load` reads the
JSON back.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping

from ..datasets.bench_format import BenchData, load_bench
from ..estimation.bounds import envelope_lines, identification_dict
from ..estimation.identify import identify as _identify
from ..estimation.identify_result import IdentificationReport
from ..utils.io import atomic_write_json
from ..utils.log import logger
from ..utils.process import one_blas_thread

__all__ = ["IdentificationResult", "identify"]

#: The file :meth:`IdentificationResult.save` writes (read by ``--friction FILE:CASE``).
IDENTIFICATION_FILE = "identification.json"


@dataclass(frozen=True)
class IdentificationResult:
    """The identification of a bench data set.

    Attributes
    ----------
    record : mapping
        ``identification.json``'s content: ``tests`` (per-test parameters and errors),
        ``bounds``, ``identifiable``, ``joint_fit``, ``friction_sets`` (``min`` /
        ``best`` / ``max``) and ``friction_envelope`` (see the formats page).
    report : IdentificationReport or None
        The fits with their data (figures); None when loaded and the data directory
        is gone.
    """

    record: Mapping[str, Any]
    report: IdentificationReport | None = None

    @property
    def success(self) -> bool:
        """At least one test converged."""
        return any(t.get("success") for t in self.record["tests"])

    @property
    def friction_sets(self) -> dict[str, dict[str, float]]:
        """The data-supported friction sets ``min`` / ``best`` / ``max`` (and the paper's
        per-parameter ``paper_min`` / ``paper_max``), as their
        :class:`~ehsa_opt.physics.params.FrictionParams` fields."""
        sets = self.record.get("friction_sets") or {}
        return {k: dict(v) for k, v in sets.items() if isinstance(v, Mapping)}

    def table(self) -> Any:
        """One row per test: file, frequency (Hz), load (ohm), success, the identified
        parameters (their units in their names), δ_F, δ_V and the force error (%)."""
        from ..utils.tables import tidy_table
        tests = self.record["tests"]
        names = sorted({k for t in tests for k in (t.get("parameters") or {})})
        cols: dict[str, Any] = {
            "file": [t["file"] for t in tests],
            "frequency_hz": [t["frequency_hz"] for t in tests],
            "load_ohm": [t["load_ohm"] for t in tests],
            "success": [bool(t["success"]) for t in tests]}
        for n in names:
            cols[n] = [float((t.get("parameters") or {}).get(n, float("nan"))) for t in tests]
        for k in ("delta_F", "delta_V", "force_relative_error_percent"):
            cols[k] = [float("nan") if t.get(k) is None else float(t[k]) for t in tests]
        return tidy_table(cols, {"frequency_hz": "Hz", "force_relative_error_percent": "%",
                                 "success": ""})

    def summary(self, json_path: str | Path = IDENTIFICATION_FILE) -> str:
        """The lines ``ehsa-opt identify`` prints (tests, errors, friction sets)."""
        lines = [] if self.report is None else [self.report.summary(json_path)]
        return "\n".join(lines + envelope_lines(self.record, json_path))

    def plot(self, ax: Any = None) -> list[Any]:
        """The identification figures (a list; nothing written; ``ax`` is not used)."""
        if self.report is None:
            raise ValueError("nothing to plot: the bench data of this result is not loaded")
        return self.report.plot(ax)

    def save(self, out_dir: str | Path) -> list[Path]:
        """Write ``identification.json`` and the figures into ``out_dir``."""
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        paths = [] if self.report is None else self.report.write(out)
        atomic_write_json(out / IDENTIFICATION_FILE, self.record)
        return [out / IDENTIFICATION_FILE, *paths]

    @classmethod
    def load(cls, out_dir: str | Path) -> IdentificationResult:
        """Read ``identification.json`` back from a folder (or the file itself); the
        report with its data when the data directory it names is there."""
        import json

        from ..utils.limits import parse_json
        p = Path(out_dir)
        path = p / IDENTIFICATION_FILE if p.is_dir() else p
        doc = parse_json(path.read_text(encoding="utf-8"), str(path))
        report = None
        if Path(str(doc.get("data_dir", ""))).is_dir():
            report = IdentificationReport.from_dict(doc)
        return cls(json.loads(json.dumps(doc)), report)


@one_blas_thread
def identify(data: BenchData | str | Path, *, starts: int = 4, jobs: int = 1, seed: int = 0,
             lenient: bool = False,
             progress: Callable[[int], None] | None = None,
             friction_law: str = "static") -> IdentificationResult:
    """Identify the friction of every test of a bench data set; nothing written.

    Parameters
    ----------
    data : BenchData or path
        A bench data directory (``bench.toml`` and the tests' CSVs, validated
        strictly first: bad data is refused before any solve) or loaded data.
    starts : int
        Multistart points per test.
    jobs : int
        Parallel processes.
    seed : int
        Seed of the start draws (same seed, same result).
    lenient : bool
        Accept data whose signals contradict ``bench.toml`` (warnings, not errors).
    progress : callable, optional
        Called with the number of finished per-test fits.
    friction_law : {"static", "lugre"}
        The friction law: the Simscape map of the velocity, or the same map as the
        steady state of a LuGre bristle (presliding; σ₀ and σ₁ identified too).

    Returns
    -------
    IdentificationResult
    """
    if not isinstance(data, BenchData):
        data = load_bench(data, lenient=lenient)
    logger.info("identify: %d tests, %d starts each", len(data.tests), starts)
    rep = _identify(data, starts=starts, jobs=jobs, seed=seed, progress=progress,
                    friction_law=friction_law)
    result = IdentificationResult(identification_dict(rep), rep)
    if not result.success:
        logger.warning("warning: identify: no test converged; see the per-test messages")
    return result
