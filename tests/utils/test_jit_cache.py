"""Compiled code in a cache of its own (ehsa_opt/utils/jit_cache.py): a command that
compiles leaves nothing in the current directory, the libraries are reused across runs,
and the compiled function computes the interpreted one's numbers."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import casadi as ca
import numpy as np
import pytest

from ehsa_opt.utils import jit_cache
from tests.paths import ROOT

needs_cc = pytest.mark.skipif(jit_cache.compiler() is None, reason="no C compiler")


def _run(argv: list[str], cwd: Path, cache: Path) -> subprocess.CompletedProcess:
    env = {**os.environ, "PYTHONPATH": str(ROOT), "EHSA_OPT_CACHE_DIR": str(cache)}
    env.pop("EHSA_OPT_NO_JIT", None)
    return subprocess.run([sys.executable, *argv], cwd=cwd, env=env, capture_output=True,
                          text=True, timeout=600)


def _libraries(cache: Path) -> dict[str, int]:
    return {f.name: f.stat().st_mtime_ns for f in sorted((cache / "jit").iterdir())}


@needs_cc
def test_simulate_leaves_the_working_folder_empty_and_reuses_the_cache(tmp_path):
    cwd, cache = tmp_path / "work", tmp_path / "cache"
    cwd.mkdir()
    problem = ROOT / "problems/quarter_car_class_c.toml"
    r = _run(["-m", "ehsa_opt", "simulate", str(problem), "--json"], cwd, cache)
    assert r.returncode == 0, r.stderr
    assert list(cwd.iterdir()) == []
    first = _libraries(cache)
    assert first and all(n.endswith(".so") and not n.startswith(".") for n in first), first
    assert (cache / "jit").stat().st_mode & 0o077 == 0  # private
    r2 = _run(["-m", "ehsa_opt", "simulate", str(problem), "--json"], cwd, cache)
    assert r2.returncode == 0
    metrics = [{k: v for k, v in json.loads(x.stdout).items() if not k.endswith("_s")}
               for x in (r, r2)]  # the same numbers (the run's wall time aside)
    assert metrics[0] == metrics[1]
    assert _libraries(cache) == first  # loaded, not compiled again
    assert list(cwd.iterdir()) == []


_BENCH_MAP = """
import numpy as np
from ehsa_opt import BenchModel, HarvesterParams, SineMotion
from ehsa_opt.datasets.synthetic import PROTOTYPE_FRICTION
from ehsa_opt.physics.bench_map import simulate_map
model = BenchModel(HarvesterParams(), ())
y, _ = simulate_map(model, SineMotion(0.008, 2.5), model.param_vector(10.0, PROTOTYPE_FRICTION),
                    np.arange(200) * 1e-3)
print(repr(float(y[0, -1])), flush=True)
import os
os._exit(0)  # as a forked worker ends: no clean-up at exit
"""


@needs_cc
def test_bench_map_compiles_into_the_cache_not_the_working_folder(tmp_path):
    """The discrepancy workflow's simulator (its forked workers, which end without the
    clean-up at exit, left jit_tmp*.c and tmp_casadi_compiler_shell* files in the working
    folder)."""
    cwd, cache = tmp_path / "work", tmp_path / "cache"
    cwd.mkdir()
    out = tmp_path / "out"
    r = _run(["-m", "ehsa_opt", "discrepancy", str(ROOT / "data/bench_prototype"), "--out",
              str(out), "--max-tests", "2", "--top", "1", "--budget-s", "0.5"], cwd, cache)
    assert r.returncode in (0, 1) and "Traceback" not in r.stderr, r.stderr
    assert list(cwd.iterdir()) == []
    assert not [f for f in out.rglob("*") if "jit_tmp" in f.name or "casadi" in f.name]
    r = _run(["-c", _BENCH_MAP], cwd, cache)
    assert r.returncode == 0, r.stderr
    assert list(cwd.iterdir()) == []
    assert any(n.startswith("radau_substep_") for n in _libraries(cache))


@needs_cc
def test_compiled_function_computes_the_interpreted_numbers(tmp_path, monkeypatch):
    monkeypatch.setenv("EHSA_OPT_CACHE_DIR", str(tmp_path))
    x, p = ca.SX.sym("x", 3), ca.SX.sym("p", 2)
    f = ca.Function("cache_probe", [x, p], [ca.vertcat(ca.sin(x[0]) * p[0],
                                                       ca.exp(x[1] - x[2]) / p[1])])
    g = jit_cache.compiled(f)
    assert g is not None
    args = (np.array([0.3, -1.2, 2.0]), np.array([4.0, 0.5]))
    assert np.array_equal(np.array(g(*args)), np.array(f(*args)))
    # mapped, as the simulators use it
    xs = np.random.default_rng(0).normal(size=(3, 7))
    assert np.array_equal(np.array(g.map(7)(xs, args[1])), np.array(f.map(7)(xs, args[1])))
    names = [q.name for q in (tmp_path / "jit").iterdir()]
    assert len(names) == 1 and names[0].startswith("cache_probe_")
    assert jit_cache.compiled(f) is not None and \
        [q.name for q in (tmp_path / "jit").iterdir()] == names


def test_cache_folder_follows_the_environment(tmp_path, monkeypatch):
    monkeypatch.delenv("EHSA_OPT_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert jit_cache.cache_dir() == tmp_path / "xdg/ehsa_opt/jit"
    monkeypatch.delenv("XDG_CACHE_HOME")
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert jit_cache.cache_dir() == tmp_path / "home/.cache/ehsa_opt/jit"
    monkeypatch.setenv("EHSA_OPT_CACHE_DIR", str(tmp_path / "mine"))
    assert jit_cache.cache_dir() == tmp_path / "mine/jit"
    assert (tmp_path / "mine/jit").stat().st_mode & 0o777 == 0o700


def test_a_cache_folder_others_can_write_is_not_used(tmp_path, monkeypatch):
    shared = tmp_path / "shared" / "jit"
    shared.mkdir(parents=True)
    shared.chmod(0o777)
    monkeypatch.setenv("EHSA_OPT_CACHE_DIR", str(tmp_path / "shared"))
    d = jit_cache.cache_dir()
    assert d != shared and d.is_dir() and d.stat().st_mode & 0o077 == 0
    link = tmp_path / "link"
    (link).mkdir()
    (link / "jit").symlink_to(tmp_path / "elsewhere", target_is_directory=True)
    (tmp_path / "elsewhere").mkdir()
    monkeypatch.setenv("EHSA_OPT_CACHE_DIR", str(link))
    assert jit_cache.cache_dir() != link / "jit"
    shutil.rmtree(tmp_path / "elsewhere")
