"""The paper end to end from a script: :func:`reproduce` and :class:`ReproduceResult`.

The report job of :mod:`ehsa_opt.pipeline.reproduce` (data, identification, quarter-car
studies, design, model discrepancy; one ``REPORT.md`` with its tables and figures) on
the embedded data or one's own bench data.  The job works in a folder — its step cache
lets an interrupted run resume — which is a private temporary folder unless ``workdir``
names one; the report's files come back in memory and ``save(folder)`` writes them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Mapping

from ..utils.log import logger

__all__ = ["ReproduceResult", "reproduce"]

#: The report's main file.
REPORT_FILE = "REPORT.md"
#: What stays in the job's folder and is not part of the report (the step cache, the
#: folder's manifest and lock).
NOT_REPORT = ("cache/",)


@dataclass(frozen=True)
class ReproduceResult:
    """The reproduction report.

    Attributes
    ----------
    files : mapping
        Every file of the report (relative POSIX path → bytes): ``REPORT.md``,
        ``tables/<step>_<k>.csv``, ``figures/…``, the steps' JSON results.
    workdir : Path or None
        The folder the job worked in (and resumes from); None when it was temporary.
    """

    files: Mapping[str, bytes]
    workdir: Path | None = None

    @property
    def report(self) -> str:
        """``REPORT.md``."""
        return self.files[REPORT_FILE].decode("utf-8")

    def summary(self) -> str:
        """The report's title line and the run log (step, computed or cached, seconds)."""
        lines = self.report.splitlines()
        head = next((ln for ln in lines if ln.startswith("# ")), "# report")
        k = next((i for i, ln in enumerate(lines) if ln.strip() == "## Run log"), None)
        log = [] if k is None else [ln for ln in lines[k + 1:] if ln.startswith("|")]
        return "\n".join([head[2:], *log])

    def table(self) -> Any:
        """The run log as a tidy table: step, this run (computed or cached), compute
        time (s)."""
        from ..utils.tables import tidy_table
        rows = [ln.strip("|").split("|") for ln in self.summary().splitlines()[3:]]
        return tidy_table({"step": [r[0].strip() for r in rows],
                           "this_run": [r[1].strip() for r in rows],
                           "compute_time_s": [float(r[2]) for r in rows]},
                          {"step": "", "this_run": ""})

    def plot(self, ax: Any = None) -> dict:
        """The report's figures as images keyed by path (``figures/…``), for
        ``matplotlib``'s ``imshow``; nothing drawn (``ax`` is not used)."""
        import io

        import matplotlib.image as mpimg
        return {name: mpimg.imread(io.BytesIO(data), format="png")
                for name, data in sorted(self.files.items()) if name.endswith(".png")}

    def save(self, out_dir: str | Path) -> list[Path]:
        """Write the report's files into ``out_dir`` (atomically, file by file); returns
        the paths written.  Saving into :attr:`workdir` writes nothing (it is there)."""
        from ..utils.io import atomic_write_bytes
        out = Path(out_dir)
        paths = [out / name for name in sorted(self.files)]
        if self.workdir is not None and out.resolve() == self.workdir.resolve():
            return paths
        for name, path in zip(sorted(self.files), paths):
            atomic_write_bytes(path, self.files[name])
        return paths

    @classmethod
    def load(cls, out_dir: str | Path) -> ReproduceResult:
        """Read a report folder back (``REPORT.md`` and the files beside it)."""
        out = Path(out_dir)
        if not (out / REPORT_FILE).is_file():
            raise ValueError(f"{out}: no {REPORT_FILE}; not a reproduction report (write "
                             f"one with `ehsa-opt reproduce --out {out}`)")
        return cls(_report_files(out))


def _report_files(folder: Path) -> dict[str, bytes]:
    """The report's files of a job folder (hidden files and the step cache left out)."""
    files = {}
    for p in sorted(folder.rglob("*")):
        rel = p.relative_to(folder).as_posix()
        if p.is_file() and not any(part.startswith(".") for part in p.relative_to(folder).parts) \
                and not rel.startswith(NOT_REPORT):
            files[rel] = p.read_bytes()
    return files


def reproduce(*, quick: bool = False, jobs: int = 2, data: str | Path | None = None,
              vehicle: str | Path | None = None, friction_bounds: str = "data",
              workdir: str | Path | None = None,
              on_message: Callable[[str], None] | None = None) -> ReproduceResult:
    """Reproduce the paper end to end; the report in memory.

    Parameters
    ----------
    quick : bool
        Fewer starts, shorter roads (minutes instead of the full run).
    jobs : int
        Parallel processes.
    data : path, optional
        One's own bench data directory (``bench.toml`` + CSVs; the harvester from its
        ``[harvester]``) instead of the embedded data; validated before any step runs.
    vehicle : path, optional
        A problem file whose ``preset`` / ``[vehicle]`` is the vehicle of the studies and
        the design (default: the passenger car).
    friction_bounds : {"data", "paper"}
        Min/max friction sets of the studies and the design: the envelope of the rod
        friction the data support, or the paper's per-parameter min/max.
    workdir : path, optional
        The folder the job works in: the report is written there as it goes and an
        interrupted run resumes from its step cache (``ehsa-opt reproduce --out``); a
        non-empty folder ehsa-opt did not write is refused.  Default: a private
        temporary folder, removed afterwards (nothing written).
    on_message : callable, optional
        Called with each progress message (default: the ``ehsa_opt`` logger, INFO).

    Returns
    -------
    ReproduceResult
    """
    import shutil
    import tempfile

    from ..pipeline.reproduce import reproduce as run_report
    if friction_bounds not in ("data", "paper"):
        raise ValueError(f"reproduce: friction_bounds {friction_bounds!r}: give 'data' or "
                         f"'paper'")
    say = on_message or logger.info
    folder = Path(workdir) if workdir is not None else Path(
        tempfile.mkdtemp(prefix="ehsa_opt_reproduce_"))
    try:
        report = run_report(out_dir=folder, quick=quick, jobs=jobs, data_dir=data,
                            vehicle=vehicle, friction_bounds=friction_bounds, log=say)
        return ReproduceResult(_report_files(Path(report).parent),
                               None if workdir is None else folder)
    finally:
        if workdir is None:
            shutil.rmtree(folder, ignore_errors=True)
