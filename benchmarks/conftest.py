"""Fixtures of the speed suite (``benchmarks/test_speed.py``, pytest-benchmark).

Not part of the default test run (``testpaths = ["tests"]``); run it with

    python -m pytest benchmarks --benchmark-timer=time.process_time --benchmark-autosave

(CPU time of this process; ``--benchmark-autosave`` appends the figures to the history in
``.benchmarks/``, ``--benchmark-compare`` compares with the last saved run).
"""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))


@pytest.fixture(autouse=True, scope="session")
def _one_blas_thread():
    """As the command line runs: BLAS on one thread (parallelism is by processes)."""
    from ehsa_opt.utils.process import single_threaded_blas
    with single_threaded_blas():
        yield


@pytest.fixture(scope="session")
def rigid_campaign(tmp_path_factory):
    """The 21-test rigid campaign of ``ehsa-opt bench generate DIR --seed 7`` (loaded)."""
    from ehsa_opt.cli import main
    from ehsa_opt.datasets.bench_format import load_bench
    path = tmp_path_factory.mktemp("rigid7") / "data"
    assert main(["bench", "generate", str(path), "--seed", "7"]) == 0
    return load_bench(path)


@pytest.fixture(scope="session")
def design_problem():
    """The design problem of ``problems/paper_design.toml`` (its motor model and limits)."""
    from ehsa_opt.design.config import load_design_config
    from ehsa_opt.design.optimize import build_problem
    return build_problem(load_design_config(ROOT / "problems" / "paper_design.toml"))
