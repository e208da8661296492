"""Kill -9 and resume gives the uninterrupted results byte for byte; the step
cache refuses truncated, altered and foreign entries; checkpoints cannot be altered
silently; pool workers die with their parent."""

from __future__ import annotations

import importlib.util
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from tests.paths import ROOT

_spec = importlib.util.spec_from_file_location("fault_injection",
                                               ROOT / "tools" / "fault_injection.py")
fi = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fi)

FAST_KEYS = ("data", "harvester", "bench_truth")


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    return tmp_path_factory.mktemp("fault")


@pytest.fixture(scope="module")
def fast_base(work):
    t0 = time.perf_counter()
    fi.run(fi.reproduce_cmd(work / "base", FAST_KEYS))
    return fi.outputs(work / "base"), time.perf_counter() - t0


def test_kill_and_resume_reproduce_default(work, fast_base):
    base, t_base = fast_base
    rng = np.random.default_rng(1)
    for k, delay in enumerate(rng.uniform(0.5 * t_base, 0.95 * t_base, 2)):
        out = work / f"k{k}"
        fi.kill_after(fi.reproduce_cmd(out, FAST_KEYS), float(delay))
        fi.run(fi.reproduce_cmd(out, FAST_KEYS))
        assert fi.outputs(out) == base


def test_damaged_cache_entries_are_recomputed_not_used(work, fast_base):
    base, _ = fast_base
    out = work / "tamper"
    fi.run(fi.reproduce_cmd(out, FAST_KEYS))
    cache = out / "cache"
    # truncated (as a non-atomic writer killed mid-write would leave it) + leftover temp file
    text = (cache / "data.json").read_text()
    (cache / "data.json").write_text(text[: len(text) // 2])
    (cache / ".data.json.abc.tmp").write_text(text[:100])
    # altered number, digest left as it was
    doc = json.loads((cache / "bench_truth.json").read_text())
    md = doc["payload"]["markdown"]
    i = next(j for j, c in enumerate(md) if c.isdigit())
    doc["payload"]["markdown"] = md[:i] + str((int(md[i]) + 1) % 10) + md[i + 1:]
    (cache / "bench_truth.json").write_text(json.dumps(doc))
    # foreign entry: another step's file under this step's name
    (cache / "harvester.json").write_text((cache / "bench_truth.json").read_text())
    r = fi.run(fi.reproduce_cmd(out, FAST_KEYS))
    log = r.stdout
    assert "data.json: unreadable" in log
    assert "bench_truth.json: its SHA-256 digest does not match" in log
    assert "harvester.json: its SHA-256 digest does not match" in log or \
        "harvester.json: it belongs to step" in log
    assert fi.outputs(out) == base
    # a clean re-run now uses every entry
    assert fi.run(fi.reproduce_cmd(out, FAST_KEYS)).stdout.count("cached (hash") == 3


def test_cache_entry_of_another_step_refused(tmp_path):
    from ehsa_opt.pipeline.cache import StepCache
    lines: list[str] = []
    c = StepCache(tmp_path, lines.append)
    c.store("a", "h1", {"markdown": "x", "figures": [], "results": {"v": float("nan")}})
    got = c.load("a", "h1")
    assert np.isnan(got["results"]["v"])  # non-finite survives, stored as standard JSON
    json.loads((tmp_path / "cache/a.json").read_text(),
               parse_constant=lambda s: pytest.fail(f"bare {s} in cache JSON"))
    (tmp_path / "cache/b.json").write_bytes((tmp_path / "cache/a.json").read_bytes())
    assert c.load("b", "h1") is None and "belongs to step 'a'" in lines[-1]
    assert c.load("a", "other-inputs") is None  # changed inputs: silent recompute


@pytest.mark.slow
def test_kill_and_resume_optimize_checkpoint(work):
    base, t_base = fi.baseline_optimize(work)
    killed, same = fi.optimize_point(work, 0, 0.75 * t_base, base)
    assert same


def test_altered_checkpoint_refused(tmp_path, capsys):
    from ehsa_opt.cli import main
    out, ck = tmp_path / "o", tmp_path / "ck"
    argv = ["optimize", str(ROOT / "problems/paper_design.toml"), *fi.OPTIMIZE_ARGS,
            "--checkpoint", str(ck), "--out", str(out)]
    assert main(argv + ["--stop-after", "2"]) in (0, 1)
    files = [f for f in ck.iterdir() if f.is_file()]
    assert files
    changed = False
    for f in files:  # alter one number in the data (text: a digit; binary: a byte)
        data = bytearray(f.read_bytes())
        for i in range(len(data) // 2, len(data)):
            if 0x30 <= data[i] <= 0x39:  # an ASCII digit (not a byte such as 0xB2, "²")
                data[i] = 0x30 + (data[i] - 0x30 + 1) % 10
                changed = True
                break
        if changed:
            f.write_bytes(bytes(data))
            break
    assert changed
    capsys.readouterr()
    assert main(argv + ["--resume", str(ck)]) == 2
    err = capsys.readouterr().err
    assert str(ck) in err and "Traceback" not in err


def test_pool_workers_die_with_parent(tmp_path):
    script = (
        "import os, sys, time, multiprocessing as mp\n"
        "from concurrent.futures import ProcessPoolExecutor\n"
        "from ehsa_opt.utils.process import die_with_parent\n"
        "die_with_parent()\n"
        "ex = ProcessPoolExecutor(2, mp_context=mp.get_context('fork'))\n"
        "fs = [ex.submit(time.sleep, 60) for _ in range(2)]\n"
        "time.sleep(0.5)\n"
        "print(' '.join(str(p) for p in ex._processes), flush=True)\n"
        "time.sleep(60)\n")
    p = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE, text=True,
                         env={**os.environ, "PYTHONPATH": str(ROOT)})
    workers = [int(w) for w in p.stdout.readline().split()]
    assert len(workers) == 2
    os.kill(p.pid, signal.SIGKILL)
    p.wait()

    def alive(pid: int) -> bool:
        try:
            return "Z" not in Path(f"/proc/{pid}/stat").read_text().split()[2]
        except FileNotFoundError:
            return False
    deadline = time.time() + 5
    while any(alive(w) for w in workers) and time.time() < deadline:
        time.sleep(0.1)
    left = [w for w in workers if alive(w)]
    for w in left:
        os.kill(w, signal.SIGKILL)
    assert not left, f"orphaned workers {left}"


def test_outputs_get_the_umask_and_json_is_standard(tmp_path):
    from ehsa_opt.utils.io import atomic_write_json, atomic_write_text
    old = os.umask(0o027)
    try:
        atomic_write_text(tmp_path / "a.txt", "x")
        assert (tmp_path / "a.txt").stat().st_mode & 0o777 == 0o640
    finally:
        os.umask(old)
    atomic_write_json(tmp_path / "b.json", {"x": float("nan"), "y": [1.0, float("inf")],
                                            "z": np.float64(2.5)})
    doc = json.loads((tmp_path / "b.json").read_text(),
                     parse_constant=lambda s: pytest.fail(f"bare {s}"))
    assert doc == {"x": None, "y": [1.0, None], "z": 2.5}


@pytest.mark.slow
def test_kill_and_resume_at_20_random_points():
    """≥ 20 random kill points of reproduce and 10 of optimize --checkpoint."""
    assert fi.main(["--points", "20", "--optimize-points", "10", "--seed", "2"]) == 0
