"""Fit and held-out tests: which tests a model is fitted on and which judge it.

* :func:`split_tests`: every third test of the sorted (load, frequency) grid is held
  out, the offset drawn from the seed; fewer than 3 tests: nothing held out;
* :func:`load_split`: a data directory with a ``validation/`` sub-directory (EMPS)
  holds that set out as a whole instead;
* :func:`spread` / :func:`crop_test`: at most ``n`` tests spread over the grid, the
  last ``n`` samples of a sine test.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ...datasets.bench_format import BenchData, BenchTest, load_bench

__all__ = ["split_tests", "load_split", "spread", "spread_within", "crop_test"]


def _grid_key(t: BenchTest) -> tuple:
    return (t.load_ohm or 0.0, t.frequency_hz or 0.0, t.file)


def split_tests(tests: Sequence[BenchTest], seed: int = 0, max_tests: int | None = None
                ) -> tuple[list[BenchTest], list[BenchTest]]:
    """Fit and held-out tests: every third test of the sorted (load, frequency) grid
    is held out (offset from ``seed``); fewer than 3 tests: nothing held out."""
    ts = sorted(tests, key=_grid_key)
    if max_tests is not None and len(ts) > max_tests:
        idx = np.unique(np.round(np.linspace(0, len(ts) - 1, max_tests)).astype(int))
        ts = [ts[i] for i in idx]
    if len(ts) < 3:
        return list(ts), []
    off = int(np.random.default_rng(seed).integers(3))
    held = [t for k, t in enumerate(ts) if k % 3 == off]
    fit = [t for k, t in enumerate(ts) if k % 3 != off]
    return fit, held


def crop_test(t: BenchTest, n: int) -> BenchTest:
    """The last ``n`` samples of a sine test (recorded tests are returned whole)."""
    if t.excitation != "sine" or t.n_samples <= n:
        return t
    k = slice(t.n_samples - n, None)
    return replace(t, time_s=t.time_s[k], displacement_m=t.displacement_m[k],
                   force_N=t.force_N[k],
                   voltage_V=t.voltage_V[k] if t.voltage_V is not None else None)


def spread(items: Sequence[Any], n: int | None) -> list[Any]:
    """At most ``n`` of ``items``, evenly spread over them (all when ``n`` is None)."""
    if n is None or len(items) <= n:
        return list(items)
    idx = np.unique(np.round(np.linspace(0, len(items) - 1, n)).astype(int))
    return [items[i] for i in idx]


def spread_within(pts: Sequence[Any], n: int | None, max_samples: int | None) -> list[Any]:
    """:func:`spread` of at most ``n`` prepared tests, fewer while their samples exceed
    ``max_samples`` (at least one test; ``max_samples`` None: no limit)."""
    n = len(pts) if n is None else min(n, len(pts))
    sub = spread(pts, n)
    while (max_samples is not None and n > 1
           and sum(pt.time_s.size for pt in sub) > max_samples):
        n -= 1
        sub = spread(pts, n)
    return sub


def load_split(data: BenchData, settings: Any) -> tuple[list, list, str]:
    """Fit and held-out tests and the name of the evaluation: a ``validation/``
    sub-directory when there is one ("validation set"), else :func:`split_tests`
    ("held-out", or "all data" when nothing is held out)."""
    path = Path(str(getattr(data, "path", "") or ""))
    vdir = path / "validation"
    if path.name and (vdir / "bench.toml").is_file():
        val = load_bench(vdir)
        return (spread(sorted(data.tests, key=lambda t: t.file), settings.max_tests),
                list(val.tests), "validation set")
    fit_t, held_t = split_tests(data.tests, settings.seed, settings.max_tests)
    return fit_t, held_t, "held-out" if held_t else "all data"
