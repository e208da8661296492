"""The speed comparison against an earlier commit (``benchmarks/compare.py``) catches a
deliberate slowdown injected in a hot path, and passes a checkout against itself."""

from __future__ import annotations

import importlib.util
import sys
import textwrap
from pathlib import Path

import pytest

from tests.paths import ROOT

#: A hot path called many times: the rod friction law on 4000 velocities, 200 calls.
HOT = textwrap.dedent("""
    import numpy as np
    from ehsa_opt.physics import friction
    v = np.linspace(-1.0, 1.0, 4000)
    law = [40.0, 30.0, 0.01, 300.0, 0.03, 0.02, 1.0, 1e-4]
    for _ in range(200):
        friction.rod_friction_N(v, law, 0.0008)
""")

#: ``sitecustomize`` of the slowed side: every call of the hot path first waits
#: ``WAIT_S`` — asleep (``sleep``: only the wall time grows) or busy (``spin``: the CPU
#: time grows, as code doing more work would).
SLOW = textwrap.dedent("""
    import time
    import ehsa_opt.physics.friction as _f
    _orig = _f.rod_friction_N
    def _slow(*a, **k):
        if {kind!r} == "sleep":
            time.sleep({wait})
        else:
            t = time.process_time()
            while time.process_time() - t < {wait}:
                pass
        return _orig(*a, **k)
    _f.rod_friction_N = _slow
""")


@pytest.fixture(scope="module")
def compare():
    spec = importlib.util.spec_from_file_location("ehsa_bench_compare",
                                                  ROOT / "benchmarks" / "compare.py")
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod
    spec.loader.exec_module(mod)
    return mod


def _case(compare):
    return compare.Case("hot_path", lambda work: [[sys.executable, "-c", HOT]])


def _slowed(compare, tmp_path: Path, kind: str, wait: float):
    d = tmp_path / kind
    d.mkdir()
    (d / "sitecustomize.py").write_text(SLOW.format(kind=kind, wait=wait), encoding="utf-8")
    return compare.Side(ROOT, f"slowed-{kind}", pythonpath=(str(d),))


def test_busy_slowdown_fails_on_cpu(compare, tmp_path):
    base = compare.Side(ROOT, "base")
    res = compare.compare_case(_case(compare), base, _slowed(compare, tmp_path, "spin", 0.004),
                               pairs=2, warmup=False, log=lambda m: None)
    why = res.verdict(compare.CPU_FACTOR, compare.WALL_FACTOR)
    assert any(w.startswith("CPU") for w in why), (res.cpu_ratios, why)
    assert compare.exit_code([res], compare.CPU_FACTOR, compare.WALL_FACTOR) == 1
    assert "FAIL: CPU" in compare.table([res], compare.CPU_FACTOR, compare.WALL_FACTOR)


def test_sleep_slowdown_fails_on_wall(compare, tmp_path):
    base = compare.Side(ROOT, "base")
    res = compare.compare_case(_case(compare), base, _slowed(compare, tmp_path, "sleep", 0.03),
                               pairs=2, warmup=False, log=lambda m: None)
    why = res.verdict(compare.CPU_FACTOR, compare.WALL_FACTOR)
    assert any(w.startswith("wall") for w in why), (res.wall_ratios, why)
    assert compare.exit_code([res], compare.CPU_FACTOR, compare.WALL_FACTOR) == 1


def test_same_code_passes(compare):
    res = compare.compare_case(_case(compare), compare.Side(ROOT, "a"),
                               compare.Side(ROOT, "b"), pairs=2, warmup=True,
                               log=lambda m: None)
    assert res.verdict(compare.CPU_FACTOR, compare.WALL_FACTOR) == [], (res.cpu_ratios,
                                                                       res.wall_ratios)
    assert compare.exit_code([res], compare.CPU_FACTOR, compare.WALL_FACTOR) == 0


def test_failing_command_is_an_error(compare):
    case = compare.Case("broken", lambda work: [[sys.executable, "-c", "raise SystemExit(3)"]])
    with pytest.raises(RuntimeError, match="exited 3"):
        compare.compare_case(case, compare.Side(ROOT, "a"), compare.Side(ROOT, "b"), pairs=1,
                             warmup=False, log=lambda m: None)
