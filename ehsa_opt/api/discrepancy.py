"""Model discrepancy from a script: :func:`discrepancy`.

The engine (:mod:`ehsa_opt.estimation.discrepancy`) on a bench data directory or its
:class:`~ehsa_opt.datasets.bench_format.BenchData`: the effects the base model misses,
named, identified and judged on held-out data by one criterion, with the same answer for
any ``jobs``, machine load or cluster.  The result stays in memory
(:class:`~ehsa_opt.estimation.discrepancy.results.DiscrepancyResult`: ``effect``,
``effects``, ``summary()``, ``table()``, ``plot()``); ``save(folder)`` writes
``discrepancy.json`` and the figures.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from ..estimation.discrepancy import DiscrepancySettings, run_discrepancy
from ..estimation.discrepancy.results import DiscrepancyResult
from ..utils.log import logger

__all__ = ["discrepancy"]


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
    if settings is None:
        settings = DiscrepancySettings(**options)
    elif options:
        import dataclasses
        settings = dataclasses.replace(settings, **options)
    if isinstance(data, (str, Path)) and not Path(data).is_dir():
        raise ValueError(f"discrepancy: {data} is not a bench data directory (bench.toml and "
                         f"the tests' CSV files); give its folder")
    return run_discrepancy(data, settings, log=logger.info)
