"""Model discrepancy from a script: :func:`discrepancy`.

The engine (:mod:`ehsa_opt.estimation.discrepancy`) on a bench data directory or its
:class:`~ehsa_opt.datasets.bench_format.BenchData`: the effects the base model misses,
named, identified and judged on held-out data by one criterion, with the same answer for
any ``jobs``, machine load or cluster.  The result stays in memory
(:class:`~ehsa_opt.estimation.discrepancy.results.DiscrepancyResult`: ``effect``,
``effects``, ``summary()``, ``table()``, ``plot()``); ``save(folder)`` writes
``discrepancy.json`` and the figures.  :func:`discrepancy_report` adds the report
(``report.md``, the true parameters' error of synthetic data) and a wall-time safety
cap: what ``ehsa-opt discrepancy`` writes.
"""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping

from ..datasets.bench_format import load_bench
from ..estimation.discrepancy import DiscrepancySettings, run_discrepancy
from ..estimation.discrepancy.results import DiscrepancyResult
from ..utils.log import logger

__all__ = ["discrepancy", "discrepancy_report", "DiscrepancyReport"]


def discrepancy(data: Any, settings: DiscrepancySettings | None = None,
                **options: Any) -> DiscrepancyResult:
    """Find, name and add the effects a bench campaign shows and the base model misses.

    Parameters
    ----------
    data : str, Path or BenchData
        A bench data directory (``bench.toml`` and the tests' CSVs; a ``validation/``
        sub-directory is the held-out set) or its loaded data.
    settings : DiscrepancySettings, optional
        The run's settings (candidates, ``jobs``, ``scheduler``, the work budget
        ``max_member_fits``, the decision ``criterion`` …); validated at construction.
    **options
        Fields of :class:`DiscrepancySettings` instead of (or on top of) ``settings``,
        e.g. ``jobs=2, max_tests=9``.

    Returns
    -------
    DiscrepancyResult
        ``success`` False when the work budget or the safety cap cut the run (``cut``
        says where); messages go to the ``ehsa_opt`` logger.
    """
    settings = _settings(settings, options)
    if isinstance(data, (str, Path)) and not Path(data).is_dir():
        raise ValueError(f"discrepancy: {data} is not a bench data directory (bench.toml and "
                         f"the tests' CSV files); give its folder")
    return run_discrepancy(data, settings, log=logger.info)


#: The files :meth:`DiscrepancyReport.save` writes (and the figures under ``figures/``).
REPORT_JSON, REPORT_MD, FIGURES_DIR = "discrepancy.json", "report.md", "figures"


@dataclass(frozen=True)
class DiscrepancyReport:
    """The model-discrepancy report of a bench data set, in memory.

    Attributes
    ----------
    record : mapping
        ``discrepancy.json``'s content: the answer (``effect``, ``effects``), every
        judged candidate, the decision rule, ``partial`` (a run cut by the work budget
        or the wall-time safety cap) and, for synthetic data, the error of the true
        parameters (``error_true_parameters``, %).
    markdown : str
        ``report.md``.
    result : DiscrepancyResult or None
        The workflow's result (tables, figures); None when the run went to a worker
        process (a wall-time safety cap) or was cut by the cap.
    figures : mapping
        The report's PNG figures (name → bytes) when ``result`` is None.
    """

    record: Mapping[str, Any]
    markdown: str
    result: DiscrepancyResult | None = None
    figures: Mapping[str, bytes] = field(default_factory=dict)

    @property
    def partial(self) -> bool:
        """The work budget or the wall-time safety cap cut the run: a stated partial
        answer (``ehsa-opt discrepancy`` exits 1)."""
        return bool(self.record.get("partial"))

    @property
    def success(self) -> bool:
        """The run finished (not :attr:`partial`)."""
        return not self.partial

    def summary(self) -> str:
        """The answer and, for synthetic data, the true parameters' error."""
        floor = self.record.get("error_true_parameters")
        return "\n".join([str(self.record.get("message", ""))] + (
            [] if floor is None else
            [f"true parameters (truth.toml) on the same tests: {floor:.3f} %"]))

    def table(self) -> Any:
        """The judged candidates (one row per candidate and round)."""
        if self.result is not None:
            return self.result.table()
        from ..utils.tables import tidy_table

        def num(v: Any) -> float:
            return float("nan") if v is None else float(v)
        rows = [c for c in self.record.get("candidates") or [] if c.get("re_identified", True)]
        return tidy_table({
            "round": [c.get("round") for c in rows], "effect": [c.get("effect") for c in rows],
            "earns": [bool(c.get("earns_its_parameters")) for c in rows],
            "earns_by": [c.get("earns_by") or "" for c in rows],
            "error_before_pct": [num(c.get("error_before")) for c in rows],
            "error_after_pct": [num(c.get("error_after")) for c in rows],
            "delta_bic_heldout": [num(c.get("delta_bic_heldout")) for c in rows]},
            {"round": "-", "earns": "", "effect": "", "earns_by": "",
             "delta_bic_heldout": "-"})

    def plot(self, ax: Any = None) -> dict:
        """The report's figures keyed by file name (needs :attr:`result`)."""
        if self.result is None:
            raise ValueError("nothing to plot: the figures of this report are PNG files "
                             "(.figures); run without a wall-time safety cap for the result")
        return self.result.plot(ax)

    def save(self, out_dir: str | Path) -> list[Path]:
        """Write ``discrepancy.json``, ``report.md`` and ``figures/`` into ``out_dir``
        (atomically, file by file); returns the paths written."""
        from ..utils.io import atomic_write_bytes, atomic_write_json, atomic_write_text
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        if self.result is not None:
            figs = self.result.write(out / FIGURES_DIR)
        else:
            figs = []
            for name, data in sorted(self.figures.items()):
                atomic_write_bytes(out / FIGURES_DIR / name, data)
                figs.append(out / FIGURES_DIR / name)
        atomic_write_json(out / REPORT_JSON, dict(self.record), indent=2)
        atomic_write_text(out / REPORT_MD, self.markdown)
        return [out / REPORT_JSON, out / REPORT_MD, *figs]

    @classmethod
    def load(cls, out_dir: str | Path) -> DiscrepancyReport:
        """Read a saved report back (``discrepancy.json``, ``report.md``, the figures)."""
        from ..utils.limits import parse_json
        out = Path(out_dir)
        doc = parse_json((out / REPORT_JSON).read_text(encoding="utf-8"),
                         str(out / REPORT_JSON))
        if not isinstance(doc, dict) or "effect" not in doc:
            raise ValueError(f"{out / REPORT_JSON}: not a discrepancy report (no 'effect')")
        md = out / REPORT_MD
        figs = {p.name: p.read_bytes() for p in sorted((out / FIGURES_DIR).glob("*.png"))}
        return cls(doc, md.read_text(encoding="utf-8") if md.is_file() else "", None, figs)


def discrepancy_report(data: Any, settings: DiscrepancySettings | None = None, *,
                       wall_cap_s: float | None = None,
                       on_message: Callable[[str], None] | None = None,
                       **options: Any) -> DiscrepancyReport:
    """The model-discrepancy report of a bench data set (:func:`discrepancy` with its
    ``report.md``, figures and, for synthetic data, the true parameters' error); nothing
    written.

    Parameters
    ----------
    data : str, Path or BenchData
        A bench data directory (its ``truth.toml``, when there, is checked before the
        work) or its loaded data.
    settings : DiscrepancySettings, optional
        As for :func:`discrepancy`; ``**options`` its fields.
    wall_cap_s : float, optional
        Wall-time safety cap, s (None or 0: none).  The run then goes to a worker process
        killed at the cap; the workflow itself starts no candidate fit after
        :func:`~ehsa_opt.pipeline.discrepancy_report.inner_budget_s`.  Not a budget: an
        answer cut by it depends on the machine's speed and load (``partial``).  The
        work budget that gives the same answer everywhere is
        ``DiscrepancySettings.max_member_fits``.
    on_message : callable, optional
        Called with each progress message (default: the ``ehsa_opt`` logger, INFO).

    Returns
    -------
    DiscrepancyReport
    """
    from ..datasets.embedded import load_truth
    from ..pipeline.discrepancy_report import inner_budget_s, report_documents
    say = on_message or logger.info
    settings = _settings(settings, options)
    path = data if isinstance(data, (str, Path)) else getattr(data, "path", None)
    if isinstance(data, (str, Path)) and not Path(data).is_dir():
        load_bench(data)  # refused: names the path and the fix
    if path is not None and Path(path).is_dir():
        load_truth(path)  # a truth.toml that cannot be used is refused before the work
    if isinstance(settings.scheduler, str):  # refused before any work, not in a worker
        from ..utils.cluster import check_scheduler
        check_scheduler(settings.scheduler)
    if not wall_cap_s:
        res = run_discrepancy(data, settings, log=say)
        doc, markdown = report_documents(res)
        report = DiscrepancyReport(doc, markdown, res)
        for line in report.summary().splitlines():
            say(line)
        return report
    inner = inner_budget_s(wall_cap_s)
    if settings.wall_cap_s is None or settings.wall_cap_s > inner:
        settings = dataclasses.replace(settings, wall_cap_s=inner)
    return _in_worker(data, settings, wall_cap_s, inner, say)


def _settings(settings: DiscrepancySettings | None, options: Mapping[str, Any]
              ) -> DiscrepancySettings:
    if settings is None:
        return DiscrepancySettings(**options)
    return dataclasses.replace(settings, **options) if options else settings


def _in_worker(data: Any, settings: DiscrepancySettings, cap_s: float, inner_s: float,
               say: Callable[[str], None]) -> DiscrepancyReport:
    """The run in a forked worker killed at ``cap_s``: the worker writes its report into a
    private temporary folder (its memory is lost with it), read back here and removed; a
    run cut by the kill is the partial answer of its progress messages."""
    import shutil
    import tempfile
    import warnings

    from ..pipeline.discrepancy_report import partial_report, write_report
    from ..utils.process import run_with_deadline
    if isinstance(data, (str, Path)):
        with warnings.catch_warnings():  # syntax and layout errors before any work
            warnings.simplefilter("ignore")
            load_bench(data, lenient=True)
    say(f"wall-time safety cap {cap_s:g} s (--wall-cap-s; 0 for none): no candidate fit "
        f"starts after {inner_s:.0f} s; work budget "
        + (f"{settings.max_member_fits} member fits" if settings.max_member_fits else "none")
        + " (--max-fits)")
    tmp = Path(tempfile.mkdtemp(prefix="ehsa_opt_discrepancy_"))
    try:
        def job(send: Callable[[str], None]) -> None:
            res = run_discrepancy(data, settings, log=send)
            write_report(res, tmp)
            send(res.message)
            floor = json.loads((tmp / REPORT_JSON).read_text()).get("error_true_parameters")
            if floor is not None:
                send(f"true parameters (truth.toml) on the same tests: {floor:.3f} %")

        run = run_with_deadline(job, cap_s, say)
        if run.error is not None:
            raise ValueError(f"discrepancy on {getattr(data, 'path', data)}: "
                             f"{run.error[0]}: {run.error[1]}")
        if not run.finished:
            doc, markdown, msg = partial_report(getattr(data, "path", data), run.messages,
                                                cap_s, run.seconds)
            say(msg)
            return DiscrepancyReport(doc, markdown)
        report = DiscrepancyReport.load(tmp)
        if report.partial and "safety cap" in str(report.record.get("cut") or ""):
            # cut by the workflow's own cap, inside the one asked for
            report = dataclasses.replace(report, record={**report.record, "budget_s": cap_s})
            say(f"partial answer: the workflow's own cap ({inner_s:.0f} s) inside the "
                f"wall-time safety cap of {cap_s:g} s reached; this partial answer depends "
                f"on the machine's speed and load")
        return report
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
