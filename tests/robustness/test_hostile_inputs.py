"""A hostile or careless user: nothing lost, nothing forged, no traceback.

One block per finding of the second fault audit (docs/robustness.md): data loss, unbounded
resources, garbage reported as success, forged cache entries, tracebacks, smaller
misleading behaviour.  Every test drives the CLI (exit status 2 and a message naming the
file, key or row and the fix) or the loader that the CLI calls.
"""

from __future__ import annotations

import io
import json
import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from ehsa_opt.cli import main
from ehsa_opt.datasets.synthetic import SyntheticSpec, write_synthetic
from tests.paths import ROOT

PAPER = ROOT / "problems/paper_design.toml"


def run(capsys, *argv) -> tuple[int, str, str]:
    try:
        rc = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse
        rc = exc.code
    cap = capsys.readouterr()
    assert "Traceback" not in cap.err
    return rc, cap.out, cap.err


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    spec = SyntheticSpec(frequencies_hz=(1.0, 2.0), loads_ohm=(47.0,), seed=21)
    out = tmp_path_factory.mktemp("bench") / "good"
    write_synthetic(out, spec, command="test")
    return out


@pytest.fixture
def bench(good, tmp_path):
    d = tmp_path / "data"
    shutil.copytree(good, d)
    return d


# =============================================================== 1. data loss
def _user_folder(tmp_path: Path) -> Path:
    d = tmp_path / "mine"
    (d / "chapter").mkdir(parents=True)
    (d / "thesis.txt").write_text("three years of work")
    (d / "chapter" / "fig.png").write_bytes(b"png")
    return d


def test_overwrite_refuses_a_folder_the_tool_did_not_write(tmp_path, capsys):
    d = _user_folder(tmp_path)
    rc, _, err = run(capsys, "bench", "generate", d, "--overwrite")
    assert rc == 2 and str(d) in err and "was not written by ehsa-opt" in err, err
    assert (d / "thesis.txt").read_text() == "three years of work"
    assert (d / "chapter" / "fig.png").is_file()
    # without --overwrite the refusal does not suggest the flag for a user's folder
    rc, _, err = run(capsys, "bench", "generate", d)
    assert rc == 2 and "--overwrite" not in err, err


def test_overwrite_refuses_a_generated_folder_with_user_files_added(tmp_path, capsys, good):
    d = tmp_path / "gen"
    shutil.copytree(good, d)
    (d / "notes.txt").write_text("mine")
    rc, _, err = run(capsys, "bench", "generate", d, "--overwrite", "--cycles", "1")
    assert rc == 2 and "notes.txt" in err, err
    assert (d / "notes.txt").read_text() == "mine"


def test_overwrite_replaces_a_folder_the_tool_wrote(tmp_path, capsys):
    d = tmp_path / "gen"
    assert run(capsys, "bench", "generate", d, "--cycles", "1")[0] == 0
    rc, _, err = run(capsys, "bench", "generate", d, "--overwrite", "--cycles", "1",
                     "--seed", "3")
    assert rc == 0, err
    assert "--seed 3" in (d / "truth.toml").read_text()


def _emps_source(d: Path, n: int = 400, cols: int = 4, vcols: int = 5, t=None) -> Path:
    d.mkdir(parents=True, exist_ok=True)
    t = np.arange(n) * 1e-3 if t is None else t
    x = 0.01 * np.sin(2 * np.pi * 2 * t)
    est = np.column_stack([t, x, x, 0.5 * np.cos(2 * np.pi * 2 * t)])[:, :cols]
    head = "time_s,position_m,reference_position_m,control_voltage_V".split(",")[:cols]
    np.savetxt(d / "emps_estimation.csv", est, delimiter=",", header=",".join(head),
               comments="")
    val = np.column_stack([t, x, x, 0.5 * np.cos(2 * np.pi * 2 * t), 0 * t])[:, :vcols]
    vh = "time_s,position_m,reference_position_m,control_voltage_V,pulse_N".split(",")[:vcols]
    np.savetxt(d / "emps_validation_pulses.csv", val, delimiter=",", header=",".join(vh),
               comments="")
    return d


def test_convert_emps_overwrite_refuses_a_user_folder(tmp_path, capsys):
    src = _emps_source(tmp_path / "src")
    d = _user_folder(tmp_path)
    rc, _, err = run(capsys, "bench", "convert-emps", src, d, "--overwrite")
    assert rc == 2 and "was not written by ehsa-opt" in err, err
    assert (d / "thesis.txt").is_file()
    out = tmp_path / "emps"
    assert run(capsys, "bench", "convert-emps", src, out)[0] == 0
    assert run(capsys, "bench", "convert-emps", src, out, "--overwrite")[0] == 0
    assert run(capsys, "bench", "check", out / "validation")[0] == 0


def test_reproduce_bad_data_deletes_nothing_in_out(tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    draft = out / ".draft.tmp"
    draft.write_text("my draft")
    look_alike = out / ".REPORT.md.abcd1234.tmp"
    look_alike.write_text("kept until the data are valid")
    rc, _, err = run(capsys, "reproduce", "--quick", "--data", tmp_path / "nodata", "--out", out,
                     "--overwrite")
    assert rc == 2 and "nodata" in err, err
    assert draft.read_text() == "my draft" and look_alike.is_file()


def test_stale_temp_cleanup_stays_inside_out(tmp_path):
    from ehsa_opt.pipeline.cache import remove_stale_temp_files
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    victim = elsewhere / ".thesis.tex.abcd1234.tmp"
    victim.write_text("not ours")
    out = tmp_path / "out"
    out.mkdir()
    (out / "figures").symlink_to(elsewhere)
    (out / "cache").symlink_to(elsewhere)
    (out / ".REPORT.md.ehsa_opt-abcd1234.tmp").symlink_to(victim)
    ours = out / ".REPORT.md.ehsa_opt-x1y2z3w4.tmp"
    ours.write_text("partial")
    user = out / ".draft.tmp"
    user.write_text("mine")
    look_alike = out / ".REPORT.md.x1y2z3w4.tmp"  # not a name ehsa-opt makes
    look_alike.write_text("mine too")
    from ehsa_opt.utils.output_folder import MANIFEST_NAME, claimed
    from ehsa_opt.utils.io import atomic_write_text
    with claimed(out, overwrite=True):
        atomic_write_text(out / "REPORT.md", "report")  # listed in the manifest
    assert "REPORT.md" in (out / MANIFEST_NAME).read_text()
    removed = remove_stale_temp_files(out)
    assert removed == [ours] and not ours.exists()
    assert victim.read_text() == "not ours" and user.is_file() and look_alike.is_file()


# =============================================================== 2. unbounded resources
def test_jobs_capped_at_cores_and_work_items(tmp_path, capsys, monkeypatch):
    import concurrent.futures as cf

    import ehsa_opt.design.sweep as sweep
    seen: list[int] = []

    class Pool(cf.ThreadPoolExecutor):
        def __init__(self, max_workers=None, **kw):
            seen.append(max_workers)
            super().__init__(max_workers=max_workers)

    monkeypatch.setattr(cf, "ProcessPoolExecutor", Pool)
    monkeypatch.setattr(sweep, "ProcessPoolExecutor", Pool, raising=False)
    p = tmp_path / "one.toml"
    p.write_text('preset = "passenger_car"\n[road]\nlength_m = 50.0\n'
                 '[sweep]\nspeed_km_per_h = [70.0]\n')
    rc, _, err = run(capsys, "sweep", p, "--jobs", "100000", "--out", tmp_path / "o")
    assert rc == 0, err
    assert "--jobs 100000" in err and "core" in err
    assert all(w is None or w <= 1 for w in seen), seen  # one case: no pool of 12


def test_checkpoint_deflate_bomb_refused_before_reading(tmp_path):
    """A 400 MB zero member deflated to ~400 KB: refused from the declared size."""
    from ehsa_opt.design.checkpoint import CHECKPOINT_FILE
    ck = tmp_path / "ck"
    ck.mkdir()
    buf = io.BytesIO()
    np.save(buf, np.zeros(50_000_000))
    with zipfile.ZipFile(ck / CHECKPOINT_FILE, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("header.npy", buf.getvalue())
    assert (ck / CHECKPOINT_FILE).stat().st_size < 2_000_000
    code = ("import sys\n"
            "from ehsa_opt.design.checkpoint import load_state\n"
            "from ehsa_opt.physics.params import ParameterError\n"
            "try:\n    load_state(sys.argv[1])\n"
            "except ParameterError as e:\n    print('refused:', e)\n"
            "hwm = [ln for ln in open('/proc/self/status') if ln.startswith('VmHWM')]\n"
            "print('peak', hwm[0].split()[1])\n")
    r = subprocess.run([sys.executable, "-c", code, str(ck)], capture_output=True, text=True,
                       env={**os.environ, "PYTHONPATH": str(ROOT)}, timeout=120)
    assert "refused:" in r.stdout and "uncompressed" in r.stdout, r.stdout + r.stderr
    peak_kb = int(r.stdout.split("peak")[-1])
    assert peak_kb < 300_000, peak_kb  # the 400 MB member was never inflated


def test_measured_profile_span_checked_before_allocation(tmp_path, capsys, monkeypatch):
    import ehsa_opt.vehicle.road as road

    class Spy:
        largest = 0

        def __getattr__(self, name):
            return getattr(np, name)

        def arange(self, n, *a, **k):
            Spy.largest = max(Spy.largest, int(n))
            return np.arange(n, *a, **k)

    monkeypatch.setattr(road, "np", Spy())
    (tmp_path / "road.csv").write_text("distance_m,elevation_m\n0,0\n500000,0.01\n")
    p = tmp_path / "p.toml"
    p.write_text('[road]\nprofile_csv = "road.csv"\nspeed_km_per_h = 50.0\n')
    monkeypatch.setenv("EHSA_OPT_MEMORY_LIMIT_GB", "0.5")
    rc, _, err = run(capsys, "simulate", p)
    assert rc == 2 and "GiB of memory" in err and "road.csv" in err, err
    assert Spy.largest < 1_000_000, Spy.largest


@pytest.mark.parametrize("argv,pattern", [
    (["optimize", PAPER, "--method", "nsga2", "--pop", "10000000"], r"--pop\b.*<= "),
    (["identify", ROOT / "data/bench_prototype", "--starts", "100000"], r"--starts\b.*<= "),
])
def test_population_and_starts_bounded(tmp_path, capsys, argv, pattern):
    rc, _, err = run(capsys, *argv, "--out", tmp_path / "o")
    assert rc == 2 and re.search(pattern, err), err


def test_n_freq_bounded(tmp_path, capsys):
    p = tmp_path / "d.toml"
    p.write_text(re.sub(r"n_freq\s*=\s*\d+", "n_freq = 100000000", PAPER.read_text()))
    rc, _, err = run(capsys, "optimize", p, "--out", tmp_path / "o")
    assert rc == 2 and "n_freq" in err and "<=" in err, err


# =============================================================== 3. garbage as success
def _identification(tmp_path: Path, sets: dict) -> Path:
    f = tmp_path / "identification.json"
    f.write_text(json.dumps({"friction_sets": sets}))
    return f


FULL = {"nut_breakaway_N": 80.0, "nut_coulomb_N": 60.0, "nut_breakaway_velocity_m_per_s": 0.02,
        "nut_viscous_Ns_per_m": 500.0, "bearing_breakaway_Nm": 0.01, "bearing_coulomb_Nm": 0.005,
        "bearing_breakaway_velocity_rad_per_s": 2.0, "bearing_viscous_Nms_per_rad": 1e-4}


@pytest.mark.parametrize("bad,pattern", [
    ({}, r"friction_sets\.max.*missing .*nut_breakaway_N"),
    ({**{k: v for k, v in FULL.items() if k != "nut_coulomb_N"}, "nut_colomb_N": 60.0},
     r"nut_colomb_N.*nut_coulomb_N"),
    ({**FULL, "nut_coulomb_N": 90.0}, r"nut_breakaway_N .* must be >= nut_coulomb_N"),
])
def test_friction_sets_must_be_complete_and_physical(tmp_path, capsys, bad, pattern):
    f = _identification(tmp_path, {"min": FULL, "best": FULL, "max": bad})
    p = ROOT / "problems/quarter_car_class_c.toml"
    rc, _, err = run(capsys, "simulate", p, "--friction", f"{f}:max")
    assert rc == 2 and str(f) in err and re.search(pattern, err), err


@pytest.mark.parametrize("value,pattern", [("NaN", "NaN"), ("null", "nut_coulomb_N"),
                                           ('"60"', "nut_coulomb_N")])
def test_friction_values_must_be_finite_numbers(tmp_path, capsys, value, pattern):
    f = tmp_path / "identification.json"
    f.write_text('{"friction_sets": {"min": %s, "best": %s, "max": %s}}' % (
        json.dumps(FULL), json.dumps(FULL), json.dumps(FULL).replace("60.0", value)))
    rc, _, err = run(capsys, "simulate", ROOT / "problems/quarter_car_class_c.toml",
                     "--friction", f"{f}:max")
    assert rc == 2 and str(f) in err and pattern in err, err


def _nsga2_checkpoint(tmp_path: Path, capsys) -> Path:
    ck = tmp_path / "ck"
    rc, _, err = run(capsys, "optimize", PAPER, "--method", "nsga2", "--pop", "8", "--gens",
                     "3", "--stop-after", "1", "--checkpoint", ck, "--out", tmp_path / "o1")
    assert rc == 0, err
    return ck


def _resign(ck: Path, edit) -> None:
    from ehsa_opt.design import checkpoint as cp
    path = ck / cp.CHECKPOINT_FILE
    with np.load(path, allow_pickle=False) as z:
        header = json.loads(bytes(z["header"]).decode())
        arrays = {k: z[k] for k in cp._ARRAYS}
    edit(header, arrays)
    header["sha256"] = cp._digest(header, arrays)
    buf = io.BytesIO()
    np.savez(buf, header=np.frombuffer(json.dumps(header).encode(), dtype=np.uint8), **arrays)
    path.write_bytes(buf.getvalue())


def _resume(tmp_path, capsys, ck):
    return run(capsys, "optimize", PAPER, "--method", "nsga2", "--pop", "8", "--gens", "3",
               "--resume", ck, "--out", tmp_path / "o2")


def test_resigned_checkpoint_with_changed_designs_refused(tmp_path, capsys):
    ck = _nsga2_checkpoint(tmp_path, capsys)

    def same_design(header, arrays):
        arrays["pop_X"][:] = arrays["pop_X"][0]
    _resign(ck, same_design)
    rc, _, err = _resume(tmp_path, capsys, ck)
    assert rc == 2 and "re-evaluated" in err and str(ck) in err, err
    assert not (tmp_path / "o2" / "pareto.csv").exists()


@pytest.mark.parametrize("what", ["history", "rng"])
def test_resigned_checkpoint_with_malformed_header_refused(tmp_path, capsys, what):
    ck = _nsga2_checkpoint(tmp_path, capsys)

    def edit(header, arrays):
        if what == "history":
            header["history"] = [1, "x"]
        else:
            header["rng"] = {"bit_generator": "PCG64", "state": "abc"}
    _resign(ck, edit)
    rc, _, err = _resume(tmp_path, capsys, ck)
    assert rc == 2 and str(ck) in err and what in err.lower(), err


def test_hv_reference_must_be_finite(tmp_path, capsys):
    p = tmp_path / "d.toml"
    text = PAPER.read_text()
    text = re.sub(r"hv_reference\s*=.*", "hv_reference = inf", text) if "hv_reference" in text \
        else text.replace("[nsga2]", "[nsga2]\nhv_reference = inf", 1)
    p.write_text(text)
    rc, _, err = run(capsys, "optimize", p, "--method", "nsga2", "--out", tmp_path / "o")
    assert rc == 2 and "hv_reference" in err and "finite" in err, err


def test_simulate_json_is_standard_json(tmp_path, capsys):
    p = tmp_path / "p.toml"
    p.write_text("[harvester]\nload_ohm = inf\n[road]\nlength_m = 60.0\n")
    rc, out, err = run(capsys, "simulate", p, "--json")
    if rc == 2:  # refusing an infinite load is fine too
        assert "load_ohm" in err
        return

    def bad_constant(name):
        raise AssertionError(f"non-standard JSON constant {name}")
    json.loads(out, parse_constant=bad_constant)


def test_implausible_vehicle_refused(tmp_path, capsys):
    p = tmp_path / "p.toml"
    p.write_text("[vehicle]\nsprung_mass_kg = 1e-9\nunsprung_mass_kg = 1e-9\n"
                 "[road]\nlength_m = 60.0\n")
    rc, _, err = run(capsys, "simulate", p)
    assert rc == 2 and "sprung_mass_kg" in err, err


def test_energy_residual_beyond_tolerance_fails_loudly(tmp_path, capsys):
    # a stiff light wheel that 200 Hz sampling cannot resolve (wheel hop ~ 450 Hz)
    p = tmp_path / "p.toml"
    p.write_text("[vehicle]\nsprung_mass_kg = 300.0\nunsprung_mass_kg = 5.0\n"
                 "tyre_stiffness_N_per_m = 4e7\n[road]\nlength_m = 60.0\nspeed_km_per_h = 10.0\n"
                 "[simulation]\nsample_rate_hz = 200.0\n")
    rc, _, err = run(capsys, "simulate", p)
    assert rc != 0 and "energy balance" in err and "sample_rate_hz" in err, err


def test_fit_that_missed_the_data_is_a_failure_even_lenient(bench, capsys):
    from ehsa_opt.datasets.bench_format import load_bench
    from ehsa_opt.estimation.identify import identify
    import warnings
    csv = bench / "f1Hz_Re47.csv"
    rows = csv.read_text().splitlines()
    body = [r.split(",") for r in rows[1:]]
    for r in body:
        r[1] = "0.001"  # constant displacement: the rod never moved
    csv.write_text(rows[0] + "\n" + "\n".join(",".join(r) for r in body) + "\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        data = load_bench(bench, lenient=True)
    rep = identify(data, starts=1, joint=False)
    bad = next(f for t, f in zip(data.tests, rep.fits) if t.file == "f1Hz_Re47.csv")
    assert not bad.success and "constant" in bad.message, bad.message
    assert all(f.success for t, f in zip(data.tests, rep.fits) if t.file != "f1Hz_Re47.csv")


# =============================================================== 4. the cache
def test_cache_key_covers_numerical_dependency_versions(monkeypatch):
    from ehsa_opt.pipeline import base
    before = base.code_digest()
    import scipy
    monkeypatch.setattr(scipy, "__version__", "0.0.1-forged")
    base.code_digest.cache_clear() if hasattr(base.code_digest, "cache_clear") else None
    assert base.code_digest() != before


def test_resigned_cache_entry_cannot_inject_markup(tmp_path):
    import hashlib
    sys.path.insert(0, str(ROOT / "tools"))
    import fault_injection as fi
    from ehsa_opt.pipeline.cache import encode
    out = tmp_path / "out"
    fi.run(fi.reproduce_cmd(out, ("data", "harvester")))
    entry = out / "cache" / "harvester.json"
    doc = json.loads(entry.read_text())
    doc.pop("sha256")
    doc["payload"]["markdown"] += ("\n\n| forged | 1 |\n|---|---|\n| x | 2 |\n\n"
                                   "<img src=\"http://evil.example/x.png\">\n")
    doc["sha256"] = hashlib.sha256(encode(doc).encode()).hexdigest()
    entry.write_text(encode(doc))
    r = fi.run(fi.reproduce_cmd(out, ("data", "harvester")))
    report = (out / "REPORT.md").read_text()
    assert "evil.example" not in report and "forged" not in report
    assert "harvester.json" in r.stdout and "not used" in r.stdout
    assert not any("forged" in f.read_text() for f in (out / "tables").glob("*.csv"))


def test_docs_say_the_cache_is_not_a_trust_boundary():
    text = (ROOT / "docs/robustness.md").read_text()
    assert "not a trust boundary" in text


# =============================================================== 5. tracebacks
def _deep_toml(n: int = 500) -> str:
    return "x = " + "[" * n + "]" * n + "\n"


def test_deep_toml_bench_and_problem(bench, tmp_path, capsys):
    (bench / "bench.toml").write_text(_deep_toml() + (bench / "bench.toml").read_text())
    rc, _, err = run(capsys, "bench", "check", bench)
    assert rc == 2 and "bench.toml" in err and "nest" in err, err
    p = tmp_path / "p.toml"
    p.write_text(_deep_toml())
    rc, _, err = run(capsys, "simulate", p)
    assert rc == 2 and str(p) in err and "nest" in err, err


def test_deep_json_identification_and_cache(tmp_path, capsys):
    f = tmp_path / "identification.json"
    f.write_text("[" * 100_000 + "]" * 100_000)
    rc, _, err = run(capsys, "simulate", ROOT / "problems/quarter_car_class_c.toml",
                     "--friction", f)
    assert rc == 2 and str(f) in err and "nest" in err, err
    from ehsa_opt.pipeline.cache import StepCache
    lines: list[str] = []
    cache = StepCache(tmp_path / "o", lines.append)
    cache.path("data").write_text('{"a":' * 100_000 + "1" + "}" * 100_000)
    assert cache.load("data", "k") is None and "not used" in lines[0]


def test_deep_json_checkpoint_header_refused(tmp_path):
    from ehsa_opt.design import checkpoint as cp
    from ehsa_opt.physics.params import ParameterError
    ck = tmp_path / "ck"
    ck.mkdir()
    arrays = {k: np.zeros((1, 1)) for k in cp._ARRAYS}
    deep = ("[" * 100_000 + "]" * 100_000).encode()
    np.savez(ck / cp.CHECKPOINT_FILE, header=np.frombuffer(deep, dtype=np.uint8), **arrays)
    with pytest.raises(ParameterError, match="nest"):
        cp.load_state(ck)


def test_profile_csv_field_over_limit(tmp_path, capsys):
    (tmp_path / "road.csv").write_text("distance_m,elevation_m\n0," + "1" * 200_000 + "\n")
    p = tmp_path / "p.toml"
    p.write_text('[road]\nprofile_csv = "road.csv"\n')
    rc, _, err = run(capsys, "simulate", p)
    assert rc == 2 and "road.csv" in err, err


def test_tiny_load_no_zero_division(bench, capsys):
    text = (bench / "bench.toml").read_text()
    (bench / "bench.toml").write_text(text.replace("load_ohm = 47.0", "load_ohm = 1e-300"))
    rc, _, err = run(capsys, "bench", "check", bench)
    assert rc == 2 and "load_ohm" in err, err


@pytest.mark.parametrize("kind", ["3col", "1row", "nan", "unsorted", "val4col"])
def test_convert_emps_bad_sources(tmp_path, capsys, kind):
    src = tmp_path / "src"
    if kind == "3col":
        _emps_source(src, cols=3)
    elif kind == "1row":
        _emps_source(src, n=1)
    elif kind == "val4col":
        _emps_source(src, vcols=4)
    else:
        _emps_source(src)
        f = src / "emps_estimation.csv"
        lines = f.read_text().splitlines()
        if kind == "nan":
            lines[50] = "nan," + lines[50].split(",", 1)[1]
        else:
            lines[50], lines[51] = lines[51], lines[50]
        f.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    rc, stdout, err = run(capsys, "bench", "convert-emps", src, out)
    assert rc == 2 and "emps_" in err and "wrote" not in stdout, err
    assert not out.exists()


def test_incomplete_truth_toml_refused_before_work(bench, tmp_path, capsys):
    (bench / "truth.toml").write_text("[effects]\n")
    rc, _, err = run(capsys, "discrepancy", bench, "--out", tmp_path / "o")
    assert rc == 2 and "truth.toml" in err and "[friction]" in err, err


# =============================================================== 6. smaller
def test_friction_from_resolved_against_the_sweep_file(tmp_path, capsys, monkeypatch):
    sub = tmp_path / "study"
    sub.mkdir()
    _identification(sub, {"min": FULL, "best": FULL, "max": FULL})
    p = sub / "s.toml"
    p.write_text('preset = "passenger_car"\n[friction]\nfrom = "identification.json"\n'
                 '[road]\nlength_m = 50.0\n[sweep]\nspeed_km_per_h = [70.0]\n')
    monkeypatch.chdir(tmp_path)
    rc, _, err = run(capsys, "sweep", p, "--out", tmp_path / "o")
    assert rc == 0, err


def test_paths_in_files_confined(tmp_path, capsys, monkeypatch):
    outside = tmp_path / "outside"
    outside.mkdir()
    (outside / "road.csv").write_text("distance_m,elevation_m\n0,0\n100,0.01\n200,0\n")
    proj = tmp_path / "proj"
    proj.mkdir()
    monkeypatch.chdir(proj)
    for ref in ("../outside/road.csv", str(outside / "road.csv")):
        p = proj / "p.toml"
        p.write_text(f'[road]\nprofile_csv = "{ref}"\n')
        rc, _, err = run(capsys, "simulate", p)
        assert rc == 2 and "outside" in err and "profile_csv" in err, err


def test_checkpoint_locked_like_out(tmp_path, capsys):
    ck = tmp_path / "ck"
    holder = subprocess.Popen(
        [sys.executable, "-c", "import sys, time; from ehsa_opt.utils.lock import output_lock\n"
         f"with output_lock({str(ck)!r}):\n    print('held', flush=True); time.sleep(60)"],
        stdout=subprocess.PIPE, text=True, env={**os.environ, "PYTHONPATH": str(ROOT)})
    try:
        assert holder.stdout.readline().strip() == "held"
        rc, _, err = run(capsys, "optimize", PAPER, "--method", "nsga2", "--pop", "8",
                         "--gens", "1", "--checkpoint", ck, "--out", tmp_path / "o")
        assert rc == 2 and str(ck) in err and f"pid {holder.pid}" in err, err
    finally:
        holder.kill()
        holder.wait()


def test_iso_class_and_profile_both_given(tmp_path, capsys):
    (tmp_path / "road.csv").write_text("distance_m,elevation_m\n0,0\n100,0.01\n200,0\n")
    p = tmp_path / "p.toml"
    p.write_text('[road]\niso_class = "D"\nprofile_csv = "road.csv"\n')
    rc, _, err = run(capsys, "simulate", p)
    assert rc == 2 and "iso_class" in err and "profile_csv" in err, err


def test_flat_profile_refused(tmp_path, capsys):
    (tmp_path / "road.csv").write_text("distance_m,elevation_m\n"
                                       + "".join(f"{k},0.02\n" for k in range(300)))
    p = tmp_path / "p.toml"
    p.write_text('[road]\nprofile_csv = "road.csv"\n')
    rc, _, err = run(capsys, "simulate", p)
    assert rc == 2 and "flat" in err, err


def test_bom_header_accepted_or_named(bench, capsys):
    f = bench / "f1Hz_Re47.csv"
    f.write_bytes(b"\xef\xbb\xbf" + f.read_bytes())
    rc, out, err = run(capsys, "bench", "check", bench)
    assert rc == 0 or ("byte-order mark" in err), err
    assert "\ufeff" not in err


def test_delimiter_named(bench, capsys):
    f = bench / "f1Hz_Re47.csv"
    f.write_text(f.read_text().replace(",", ";"))
    rc, _, err = run(capsys, "bench", "check", bench)
    assert rc == 2 and "';'" in err and "comma" in err, err


def test_middle_row_not_called_last(bench, capsys):
    f = bench / "f1Hz_Re47.csv"
    lines = f.read_text().splitlines()
    lines[10] = lines[10].rsplit(",", 1)[0]
    f.write_text("\n".join(lines) + "\n")
    rc, _, err = run(capsys, "bench", "check", bench)
    assert rc == 2 and "row 11" in err and "last row" not in err, err


def test_nul_in_file_name(bench, capsys):
    text = (bench / "bench.toml").read_text()
    (bench / "bench.toml").write_text(text.replace('"f1Hz_Re47.csv"', '"f1Hz\\u0000.csv"'))
    rc, _, err = run(capsys, "bench", "check", bench)
    assert rc == 2 and "embedded null byte" not in err and "control character" in err, err


def test_no_jit_folders_left_behind(tmp_path):
    code = ("from ehsa_opt.physics.params import VehicleParams, RoadParams\n"
            "from ehsa_opt.vehicle.simulate import simulate_quarter_car\n"
            "simulate_quarter_car(VehicleParams(), road=RoadParams(length_m=60.0))\n")
    env = {**os.environ, "PYTHONPATH": str(ROOT), "TMPDIR": str(tmp_path)}
    subprocess.run([sys.executable, "-c", code], check=True, env=env, timeout=300)
    assert not list(tmp_path.glob("ehsa_opt_jit_*"))
