"""Every bad input a new user tried, through the CLI: exit status 2, a message
that names the file (row or key) and the fix, never a traceback."""

from __future__ import annotations

import errno
import os
import re
import shutil
from pathlib import Path

import numpy as np
import pytest

from ehsa_opt.cli import main
from ehsa_opt.datasets.synthetic import SyntheticSpec, write_synthetic
from tests.paths import ROOT

CSV = "f1Hz_Re47.csv"


def run(capsys, *argv: str) -> tuple[int, str]:
    try:
        rc = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse
        rc = exc.code
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return rc, err


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    spec = SyntheticSpec(frequencies_hz=(1.0, 2.0), loads_ohm=(47.0,), seed=21)
    out = tmp_path_factory.mktemp("bench") / "good"
    write_synthetic(out, spec, command="test")
    return out


@pytest.fixture
def bad(good, tmp_path):
    d = tmp_path / "data"
    shutil.copytree(good, d)
    return d


def edit_column(d: Path, col: int, fn, rows: slice = slice(None)) -> None:
    p = d / CSV
    lines = p.read_text().splitlines()
    body = [ln.split(",") for ln in lines[1:]]
    values = np.array([[float(v) for v in r] for r in body])
    values[rows, col] = fn(values[rows, col])
    p.write_text(lines[0] + "\n" + "\n".join(",".join(repr(float(v)) for v in r)
                                              for r in values) + "\n")


def edit_toml(d: Path, old: str, new: str, count: int = 1) -> None:
    p = d / "bench.toml"
    text = p.read_text()
    assert old in text
    p.write_text(text.replace(old, new, count))


def refused(capsys, d: Path, *patterns: str, command: str = "check") -> str:
    argv = ["bench", "check", d] if command == "check" else \
        ["identify", d, "--out", d.parent / "out"]
    rc, err = run(capsys, *argv)
    assert rc == 2, err
    for pat in patterns:
        assert re.search(pat, err), (pat, err)
    return err


# ---------------------------------------------------------------- bench data by physics
def test_valid_data_pass(good, capsys):
    for d in (good, ROOT / "data/bench_prototype", ROOT / "data/emps",
              ROOT / "data/emps/validation"):
        rc, _ = run(capsys, "bench", "check", d)
        assert rc == 0


def test_time_in_ms(bad, capsys):
    edit_column(bad, 0, lambda t: t * 1e3)
    refused(capsys, bad, CSV, r"time_s", r"is time in ms\? Convert it to seconds")


def test_force_in_kN(bad, capsys):
    edit_column(bad, 2, lambda f: f * 1e-3)
    refused(capsys, bad, CSV, r"force_N", r"kN\? Convert it to newtons")


def test_voltage_in_mV(bad, capsys):
    edit_column(bad, 3, lambda v: v * 1e3)
    refused(capsys, bad, CSV, r"voltage_V", r"mV\? Convert it to volts")


def test_declared_frequency_not_in_signal(bad, capsys):
    edit_toml(bad, "frequency_hz = 1.0", "frequency_hz = 1.5")
    refused(capsys, bad, CSV, r"oscillates at 1 Hz", r"frequency_hz = 1.5",
            r"fix 'frequency_hz'")


def test_declared_amplitude_not_in_signal(bad, capsys):
    edit_toml(bad, "amplitude_m = 0.015", "amplitude_m = 0.025")
    refused(capsys, bad, CSV, r"amplitude_m = 0.025", r"fix 'amplitude_m'")


def test_declared_load_not_in_voltage(bad, capsys):
    edit_toml(bad, "load_ohm = 47.0", "load_ohm = 15.0")
    refused(capsys, bad, CSV, r"load_ohm = 15", r"check 'load_ohm'")


def test_150_Hz_sampled_at_1_kHz(bad, capsys):
    edit_toml(bad, "frequency_hz = 1.0", "frequency_hz = 150.0")
    refused(capsys, bad, CSV, r"samples per cycle", r"record at a higher rate")


@pytest.mark.parametrize("col,name", [(1, "displacement_m"), (2, "force_N")])
def test_all_zero_signal(bad, capsys, col, name):
    edit_column(bad, col, lambda v: 0.0 * v)
    refused(capsys, bad, CSV, rf"'{name}' is constant", r"Record the")


def test_force_1e308(bad, capsys):
    edit_column(bad, 2, lambda v: np.full_like(v, 1e308), rows=slice(40, 41))
    refused(capsys, bad, CSV, r"row 42, column 'force_N'", r"repair or remove")


def test_identify_refuses_before_solving_and_lenient_warns(bad, capsys):
    edit_column(bad, 2, lambda f: f * 1e-3)
    refused(capsys, bad, CSV, r"kN", command="identify")
    rc, _ = run(capsys, "bench", "check", bad, "--lenient")
    assert rc == 0


def test_lenient_lists_warnings(bad, capsys):
    edit_column(bad, 3, lambda v: v * 1e3)
    assert main(["bench", "check", str(bad), "--lenient"]) == 0
    assert re.search(r"warning: f1Hz_Re47.csv: column 'voltage_V'", capsys.readouterr().out)


def test_file_outside_data_directory(bad, tmp_path, capsys):
    shutil.copy(bad / CSV, tmp_path / "outside.csv")
    edit_toml(bad, f'file = "{CSV}"', 'file = "../outside.csv"')
    refused(capsys, bad, r"bench.toml \[\[test\]\] #1", r"outside the data directory",
            r"copy the CSV into the data directory")


def test_symlink_outside_data_directory(bad, tmp_path, capsys):
    shutil.copy(bad / CSV, tmp_path / "outside.csv")
    (bad / CSV).unlink()
    (bad / CSV).symlink_to(tmp_path / "outside.csv")
    refused(capsys, bad, r"bench.toml", r"symlink that points outside", r"copy the CSV")


def test_same_csv_listed_twice(bad, capsys):
    edit_toml(bad, 'file = "f2Hz_Re47.csv"', f'file = "./{CSV}"')
    refused(capsys, bad, r"bench.toml \[\[test\]\] #2", r"listed twice",
            r"remove the duplicate")


# ---------------------------------------------------------------- simulate: resources
def problem(tmp_path: Path, text: str, name: str = "p.toml", raw: bytes | None = None) -> Path:
    p = tmp_path / name
    if raw is not None:
        p.write_bytes(raw)
    else:
        p.write_text(text)
    return p


@pytest.mark.parametrize("text,patterns", [
    ("[road]\nlength_m = 1e7\n", [r"\[road\]", r"length_m", r"<= 1e\+06"]),       # 10 000 km
    ("[road]\nlength_m = 1e6\n", [r"GiB of memory", r"shorten \[road\] length_m"]),
    ("[road]\nlength_m = 500.0\n[simulation]\nsample_rate_hz = 1e8\n",
     [r"GiB of memory", r"lower \[simulation\] sample_rate_hz"]),
    ("[road]\nlength_m = 100.0\n[simulation]\nsettle_s = 60.0\n",
     [r"settle_s = 60 s is not shorter than the road", r"shorten \[simulation\] settle_s"]),
    ("[road]\nseed = -1\n", [r"\[road\]: seed = -1", r"use e.g. seed = 0"]),
])
def test_simulate_refuses_up_front(tmp_path, capsys, text, patterns):
    p = problem(tmp_path, text)
    rc, err = run(capsys, "simulate", p)
    assert rc == 2 and str(p) in err, err
    for pat in patterns:
        assert re.search(pat, err), (pat, err)


def test_latin1_problem_and_road_csv(tmp_path, capsys):
    p = problem(tmp_path, "", raw="# route de montagne, d\xe9but\n[road]\n".encode("latin-1"))
    rc, err = run(capsys, "simulate", p)
    assert rc == 2 and str(p) in err and "re-save it as UTF-8" in err
    csv = tmp_path / "road.csv"
    csv.write_bytes("distance_m,elevation_m\n0,0\n1,0.001\n# \xe9\n".encode("latin-1"))
    p = problem(tmp_path, '[road]\nprofile_csv = "road.csv"\n', name="q.toml")
    rc, err = run(capsys, "simulate", p)
    assert rc == 2 and "road.csv" in err and "UTF-8" in err


# ---------------------------------------------------------------- CLI outputs checked first
OUT_COMMANDS = [
    ("identify", ROOT / "data/bench_prototype"),
    ("discrepancy", ROOT / "data/bench_prototype"),
    ("sweep", ROOT / "problems/sweep_friction.toml"),
    ("optimize", ROOT / "problems/paper_design.toml"),
    ("reproduce", None),
]


@pytest.mark.parametrize("command,arg", OUT_COMMANDS)
def test_out_is_a_file_refused_before_work(tmp_path, capsys, command, arg):
    f = tmp_path / "out.txt"
    f.write_text("not a folder")
    argv = [command] + ([arg] if arg else []) + ["--out", f]
    rc, err = run(capsys, *argv)
    assert rc == 2 and "--out" in err and str(f) in err and "give a folder" in err


def test_checkpoint_is_a_file_and_read_only_out(tmp_path, capsys, monkeypatch):
    f = tmp_path / "ck"
    f.write_text("x")
    rc, err = run(capsys, "optimize", ROOT / "problems/paper_design.toml", "--method", "nsga2",
                  "--out", tmp_path / "o", "--checkpoint", f)
    assert rc == 2 and "--checkpoint" in err and str(f) in err
    # a folder that is not writable (we may be root: simulate what os.access reports)
    real = os.access
    monkeypatch.setattr(os, "access", lambda p, m, **kw: False if "ro" in str(p) else
                        real(p, m, **kw))
    (tmp_path / "ro").mkdir()
    rc, err = run(capsys, "identify", ROOT / "data/bench_prototype", "--out",
                  tmp_path / "ro" / "sub")
    assert rc == 2 and "is not writable" in err and "choose a folder you can write to" in err


def test_disk_full_and_read_only_filesystem_during_work(tmp_path, capsys, monkeypatch):
    import ehsa_opt.datasets.bench_format as bf

    for code, fix in ((errno.ENOSPC, "free some space"), (errno.EROFS, "choose a folder")):
        def fail(*a, code=code, **kw):
            raise OSError(code, os.strerror(code), str(tmp_path / "gen"))
        monkeypatch.setattr(bf.tempfile, "mkdtemp", fail)
        rc, err = run(capsys, "bench", "generate", tmp_path / "gen")
        assert rc == 2 and str(tmp_path / "gen") in err and fix in err, err


@pytest.mark.parametrize("option", ["--pop", "--gens"])
def test_zero_population_or_generations_refused(tmp_path, capsys, option):
    rc, err = run(capsys, "optimize", ROOT / "problems/paper_design.toml", option, "0",
                  "--out", tmp_path / "o")
    assert rc == 2 and option in err and "must be >= 1" in err


def test_two_runs_into_one_folder_refused(tmp_path, capsys):
    import subprocess
    import sys
    out = tmp_path / "out"
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time; from ehsa_opt.utils.lock import output_lock\n"
         f"with output_lock({str(out)!r}):\n    print('held', flush=True); time.sleep(60)"],
        stdout=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    try:
        assert holder.stdout.readline().strip() == "held"
        rc, err = run(capsys, "reproduce", "--quick", "--out", out)
        assert rc == 2 and str(out) in err and f"pid {holder.pid}" in err
        assert "choose another --out" in err
    finally:
        holder.kill()  # kill -9: the kernel drops the flock
        holder.wait()
    from ehsa_opt.utils.lock import output_lock
    with output_lock(out):  # the stale lock file does not block
        pass


def test_an_unknown_member_is_refused_with_the_known_ones(tmp_path, capsys):
    """``discrepancy --with`` names a member the engine does not have: exit 2 before any
    work, the message lists the members, the output folder is not created."""
    out = tmp_path / "o"
    rc, err = run(capsys, "discrepancy", ROOT / "data/bench_prototype", "--out", out,
                  "--with", "load_cell")
    assert rc == 2 and "load_cell" in err and "force_sensor" in err
    assert not out.exists()
