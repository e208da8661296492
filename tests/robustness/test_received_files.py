"""Received files through one loader discipline: identification.json (CLI and library
reloads), the data it names, motor catalogues, rig files and bench CSVs.

Every case is a command or an API call with a crafted file: exit status 2 (or the
product's own input error) and a message naming the file and key and the fix — never a
traceback, never a damaged value accepted.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from ehsa_opt.cli import main
from ehsa_opt.datasets.bench_format import BenchDataError
from ehsa_opt.estimation.bounds import FrictionBounds
from ehsa_opt.estimation.identify_result import IdentificationReport
from ehsa_opt.estimation.rod_law import FrictionSamples, RodLawFit, rod_law_fit
from ehsa_opt.physics.friction import rod_friction_N
from ehsa_opt.physics.motor import load_catalogue
from ehsa_opt.physics.params import FrictionParams, ParameterError
from tests.paths import ROOT

LEAD = 5e-3 / (2 * math.pi)  # Table 1's lead: a bench.toml without [harvester]
BEST = FrictionParams(60.0, 40.0, 0.01, 150.0, 0.02, 0.015, 1.0, 3e-5)
MIN = FrictionParams(50.0, 35.0, 0.01, 140.0, 0.015, 0.012, 1.0, 2e-5)
MAX = FrictionParams(70.0, 45.0, 0.01, 160.0, 0.025, 0.02, 1.0, 4e-5)
QC = ROOT / "problems/quarter_car_class_c.toml"


def run(capsys, *argv) -> tuple[int, str, str]:
    try:
        rc = main([str(a) for a in argv])
    except SystemExit as exc:
        rc = exc.code
    cap = capsys.readouterr()
    assert "Traceback" not in cap.err
    return rc, cap.out, cap.err


@pytest.fixture(scope="module")
def law() -> RodLawFit:
    return make_law()


def make_law() -> RodLawFit:
    """A rod-friction law fitted on three noisy sines (peak <= 0.28 m/s)."""
    rng = np.random.default_rng(4)
    vs, ys = [], []
    for f in (0.5, 1.5, 3.0):
        t = np.arange(0, 2 / f, 2e-3)
        v = 2 * math.pi * f * 0.015 * np.cos(2 * math.pi * f * t)
        vs.append(v)
        ys.append(np.asarray(rod_friction_N(v, BEST, LEAD)) + rng.normal(0, 2.0, v.size))
    return rod_law_fit(FrictionSamples(list("abc"), vs, ys), BEST.as_dict(), LEAD)


def bounds_doc(law: RodLawFit) -> dict:
    """What FrictionBounds.to_dict writes, for sets MIN <= BEST <= MAX."""
    v = np.concatenate([np.geomspace(1e-3, 0.02, 12), np.linspace(0.03, 3.0, 30)])
    rod = {c: np.asarray(rod_friction_N(v, s, LEAD)) for c, s in
           (("min", MIN), ("best", BEST), ("max", MAX))}
    fb = FrictionBounds(v, np.vstack([rod["best"]]), rod["min"], rod["max"], rod["best"],
                        np.vstack([rod["min"], rod["max"]]),
                        {"min": MIN, "best": BEST, "max": MAX}, rod, {"min": MIN, "max": MAX},
                        {"min": rod["min"], "max": rod["max"]}, LEAD, ["a.csv"],
                        law=law.to_dict(), data_range_m_per_s=(0.005, 0.236),
                        test_peak_m_per_s={"a.csv": 0.236})
    return json.loads(fb.to_json())


@pytest.fixture
def ident(law, tmp_path) -> tuple[Path, dict]:
    """identification.json next to its bench data (data_dir relative to the file)."""
    (tmp_path / "bench").mkdir()
    (tmp_path / "bench" / "bench.toml").write_text("[rig]\nname = 'r'\n")
    doc = {"data_dir": "bench", "tests": [], **bounds_doc(law)}
    p = tmp_path / "identification.json"
    p.write_text(json.dumps(doc))
    return p, doc


def edited(path: Path, doc: dict, edit) -> Path:
    doc = json.loads(json.dumps(doc))
    edit(doc)
    path.write_text(json.dumps(doc))
    return path


def the_law(d: dict) -> dict:
    return d["friction_envelope"]["extrapolation_band"]["law"]


# ================================================================ plan-tests
@pytest.fixture
def rig(tmp_path) -> Path:
    r = tmp_path / "rig.toml"
    r.write_text("[rig]\nstroke_m = 0.1\npeak_velocity_m_per_s = 1.5\n")
    return r


def plan(capsys, ident_path, rig, out) -> tuple[int, str]:
    rc, _, err = run(capsys, "plan-tests", ident_path, "--vehicle", "quarter_car_class_c",
                     "--rig", rig, "--out", out)
    return rc, err


@pytest.mark.parametrize("edit,pattern", [
    (lambda d: the_law(d).pop("parameters"), r"law: no 'parameters'"),
    (lambda d: the_law(d).__setitem__("parameters", [1, 2]), r"law\.parameters: must be a table"),
    (lambda d: the_law(d).__setitem__("free", ["nut_coulomb_N", "nut_colomb_N"]),
     r"law\.free\[1\]: unknown parameter 'nut_colomb_N'; did you mean 'nut_coulomb_N'"),
    (lambda d: the_law(d).__setitem__("covariance", "identity"), r"law\.covariance: must be a list"),
    (lambda d: the_law(d).__setitem__("covariance", [[1.0, 0.0], [0.0, 1.0]]),
     r"law\.covariance: has 2 values, expected"),
    (lambda d: the_law(d).__setitem__("covariance", (-np.eye(len(the_law(d)["free"]))).tolist()),
     r"law\.covariance: is not positive semi-definite"),
    (lambda d: the_law(d).__setitem__("n_effective", 0), r"law\.n_effective: 0 must be >= 1"),
    (lambda d: the_law(d).__setitem__("lead_m_per_rad", 0), r"law\.lead_m_per_rad: 0 must be > 0"),
    (lambda d: the_law(d).__setitem__("covariance", np.zeros((len(the_law(d)["free"]),) * 2
                                                             ).tolist()), r"covariance: is zero"),
    (lambda d: the_law(d).__setitem__("residual_rms_N", 0.0), r"residual_rms_N: 0.0 must be > 0"),
    (lambda d: the_law(d).__setitem__("test_n_effective", [0.0] * len(the_law(d)[
        "test_n_samples"])), r"test_n_effective\[0\]: 0.0 must be >= 1"),
])
def test_plan_tests_refuses_a_damaged_law(ident, rig, tmp_path, capsys, edit, pattern):
    import re
    p = edited(ident[0], ident[1], edit)
    rc, err = plan(capsys, p, rig, tmp_path / "out")
    assert rc == 2 and str(p) in err and re.search(pattern, err), err
    assert "re-run `ehsa-opt identify`" in err and not (tmp_path / "out").exists()


def test_plan_tests_harvester_from_data_dir_checked(ident, rig, tmp_path, capsys, monkeypatch):
    p, doc = ident
    monkeypatch.chdir(tmp_path / "bench")  # data_dir is resolved against the file, not here
    rc, err = plan(capsys, p, rig, tmp_path / "ok")
    assert rc == 0, err
    toml = tmp_path / "bench" / "bench.toml"
    toml.write_text("[harvester]\nlead_mm_per_rv = 5.0\n")           # a typo: no TypeError
    rc, err = plan(capsys, p, rig, tmp_path / "o1")
    assert rc == 2 and str(toml) in err and "did you mean 'lead_mm_per_rev'" in err, err
    toml.write_text("[harvester]\nlead_mm_per_rev = 4.0\n")          # another rig's data
    rc, err = plan(capsys, p, rig, tmp_path / "o2")
    assert rc == 2 and "not the lead the identification used" in err, err
    toml.unlink()                                                      # data moved
    rc, err = plan(capsys, p, rig, tmp_path / "o3")
    assert rc == 2 and "moved or were deleted" in err and "data_dir" in err, err
    assert not any((tmp_path / f"o{k}").exists() for k in (1, 2, 3))


# ================================================================ --friction
@pytest.mark.parametrize("edit,pattern", [
    (lambda d: d["velocity_range"].__setitem__("campaign_m_per_s", []),
     r"campaign_m_per_s: has 0 values, expected 2"),
    (lambda d: d["velocity_range"].__setitem__("campaign_m_per_s", [0.005, None]),
     r"campaign_m_per_s\[1\]: null is not a finite number"),
    (lambda d: d["velocity_range"].__setitem__("campaign_m_per_s", [0, 1e300]),
     r"campaign_m_per_s\[1\]: 1e\+300 must be <= 10"),
    (lambda d: d["velocity_range"].__setitem__("campaign_m_per_s", [0.2, 0.1]),
     r"not ordered"),
    (lambda d: (d.pop("velocity_range"),
                d["friction_envelope"]["velocity_m_per_s"].__setitem__(3, "0.1")),
     r"velocity_m_per_s\[3\]: '0.1' is not a finite number"),
    (lambda d: d["friction_sets"].update(min=d["friction_sets"]["max"],
                                         max=d["friction_sets"]["min"]),
     r"is above that of.*swapped"),
    (lambda d: d["friction_sets"]["max"].__setitem__("nut_coulomb_N", -5.0), r"nut_coulomb_N"),
    (lambda d: d["friction_sets"]["max"].update(nut_colomb_N=d["friction_sets"]["max"].pop(
        "nut_coulomb_N")), r"unknown key 'nut_colomb_N'; did you mean 'nut_coulomb_N'"),
])
def test_friction_file_refused_before_work(ident, capsys, edit, pattern):
    import re
    p = edited(ident[0], ident[1], edit)
    rc, _, err = run(capsys, "simulate", QC, "--friction", f"{p}:max")
    assert rc == 2 and str(p) in err and re.search(pattern, err), err


def test_utf16_identification_keeps_its_velocity_range(ident, capsys):
    p, doc = ident
    p.write_bytes(json.dumps(doc).encode("utf-16"))
    rc, out, err = run(capsys, "simulate", QC, "--friction", f"{p}:max")
    assert rc == 0, err
    assert "identified 0.236 m/s" in out and "identified 0.33" not in out  # not the embedded


def test_latin1_identification_named(ident, capsys):
    p, doc = ident
    doc = {**doc, "rig": "banc d'essai é"}
    p.write_bytes(json.dumps(doc, ensure_ascii=False).encode("latin-1"))
    rc, _, err = run(capsys, "simulate", QC, "--friction", f"{p}:max")
    assert rc == 2 and str(p) in err and "not UTF-8" in err and "Latin-1" in err, err


# ================================================================ library reloads
def test_library_reloads_refuse_what_the_cli_refuses(law, tmp_path):
    good = bounds_doc(law)
    back = FrictionBounds.from_json(json.dumps(good))
    assert back.ordered() and back.sets["max"] == MAX
    deep = "[" * 5000 + "]" * 5000
    for load in (FrictionBounds.from_json, IdentificationReport.from_json):
        with pytest.raises(ParameterError, match="nested more than 64 levels"):
            load(deep)
        with pytest.raises(ParameterError, match="non-standard JSON constant NaN"):
            load(json.dumps(good).replace("150.0", "NaN", 1))
    bad = json.loads(json.dumps(good))
    bad["friction_sets"]["min"]["nut_coulomb_N"] = -1.0
    with pytest.raises(ParameterError, match=r"friction_sets\.min.*nut_coulomb_N"):
        FrictionBounds.from_dict(bad)
    bad = json.loads(json.dumps(good))
    bad["friction_sets"]["best"]["nut_viscus_Ns_per_m"] = bad["friction_sets"]["best"].pop(
        "nut_viscous_Ns_per_m")
    with pytest.raises(ParameterError, match="did you mean 'nut_viscous_Ns_per_m'"):
        FrictionBounds.from_dict(bad)
    bad = json.loads(json.dumps(good))
    bad["friction_envelope"]["lower_N"] = bad["friction_envelope"]["lower_N"][:-1]
    with pytest.raises(ParameterError, match=r"lower_N: has \d+ values, expected"):
        FrictionBounds.from_dict(bad)
    with pytest.raises(ParameterError, match=r"tests\[0\]: no 'file'"):
        IdentificationReport.from_dict({**good, "data_dir": "x", "tests": [{}], "bounds": {},
                                        "identifiable": {}})
    with pytest.raises(ParameterError, match=r"bounds\.nut_coulomb_N.*not ordered"):
        IdentificationReport.from_dict({**good, "data_dir": "x", "tests": [],
                                        "bounds": {"nut_coulomb_N": [5.0, 1.0]},
                                        "identifiable": {}})
    with pytest.raises(ParameterError, match="law: no 'parameters'"):
        RodLawFit.from_dict({k: v for k, v in law.to_dict().items() if k != "parameters"},
                            "law")


# ================================================================ motor catalogues
def catalogue_problem(tmp_path: Path, name: str) -> Path:
    text = (ROOT / "problems/catalogue_design.toml").read_text()
    p = tmp_path / "p.toml"
    p.write_text(text.replace('catalogue = "dc_generators"', f'catalogue = "{name}"'))
    return p


@pytest.mark.parametrize("name,content,pattern", [
    ("nested/dc_generators.toml", None, r"'nested/dc_generators.toml': no such file"),
    ("nested/c.toml", b"motor = [1, 2]\n", r"motor #1 is 1, not a table"),
    ("nested/c.toml", b"x = " + b"[" * 5000 + b"]" * 5000 + b"\n", "nested more than 64"),
    ("nested/c.toml", '[[motor]]\nname = "Moteur é"\n'.encode("latin-1"), r"not UTF-8.*Latin-1"),
    ("dc_generator", None, r"did you mean 'dc_generators'"),
])
def test_catalogue_refused_naming_the_file(tmp_path, capsys, name, content, pattern):
    import re
    if content is not None:
        (tmp_path / "nested").mkdir()
        (tmp_path / name).write_bytes(content)
    p = catalogue_problem(tmp_path, name)
    rc, _, err = run(capsys, "optimize", p, "--out", tmp_path / "o")
    assert rc == 2 and re.search(pattern, err) and ("p.toml" in err or name in err), err
    assert not (tmp_path / "o").exists()


def test_catalogue_relative_to_the_problem_and_utf16(tmp_path, monkeypatch):
    shipped = ROOT / "ehsa_opt/data/motors/dc_generators.toml"
    (tmp_path / "mine").mkdir()
    (tmp_path / "mine" / "m.toml").write_bytes(shipped.read_text().encode("utf-16"))
    monkeypatch.chdir(ROOT)
    motors = load_catalogue("mine/m.toml", tmp_path)
    assert [m.name for m in motors] == [m.name for m in load_catalogue()]
    with pytest.raises(ParameterError, match="no such file"):
        load_catalogue("mine/m.toml")  # not in the working directory: no shipped fallback
    bad = shipped.read_text().replace("motor_inertia_gcm2 = ", "motor_inertia_gcm2 = 1e9 # ", 1)
    (tmp_path / "mine" / "m.toml").write_text(bad)
    with pytest.raises(ParameterError, match=r"\[\[motor\]\] #1 .*motor_inertia_gcm2"):
        load_catalogue("mine/m.toml", tmp_path)


# ================================================================ rig files
@pytest.mark.parametrize("line,pattern", [
    ("sample_rate_hz = 1e12", r"would record .* samples"),
    ("cycles = 1e9", r"would record .* samples"),
    ("min_frequency_hz = 1e-9\nmax_frequency_hz = 1.0", r"would record .* samples"),
    ("loads_ohm = [" + ", ".join(["10.0"] * 500) + "]", r"500 resistors, at most 100"),
])
def test_huge_rig_values_refused_before_allocation(ident, tmp_path, capsys, line, pattern):
    import re
    rig = tmp_path / "rig.toml"
    rig.write_text(f"[rig]\n{line}\n")
    rc, err = plan(capsys, ident[0], rig, tmp_path / "o")
    assert rc == 2 and str(rig) in err and re.search(pattern, err) and "memory" not in err, err


# ================================================================ bench CSVs
_CHILD = """
import sys
from ehsa_opt.cli import main
rc = main(["bench", "check", sys.argv[1]])
hwm = next(int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmHWM"))
print(rc, hwm * 1024)
"""


@pytest.mark.parametrize("raise_limit", [False, True])
def test_sparse_1gib_csv_bounded(tmp_path, raise_limit):
    from ehsa_opt.datasets.synthetic import SyntheticSpec, write_synthetic
    d = write_synthetic(tmp_path / "b", SyntheticSpec(frequencies_hz=(1.0, 2.0),
                                                      loads_ohm=(47.0,), seed=5))
    csv = d / "f2Hz_Re47.csv"
    with csv.open("r+b") as fh:
        fh.truncate(2 ** 30)  # a sparse file: a valid head, then a hole of zero bytes
    env = {"PATH": "/usr/bin:/bin", "PYTHONPATH": str(ROOT), "EHSA_OPT_QUIET": "1"}
    if raise_limit:
        env["EHSA_OPT_MAX_CSV_MB"] = "4096"
    r = subprocess.run([sys.executable, "-c", _CHILD, str(d)], capture_output=True, text=True,
                       env=env, timeout=120)
    rc, peak = r.stdout.split()
    assert int(rc) == 2 and "Traceback" not in r.stderr and "f2Hz_Re47.csv" in r.stderr
    assert ("NUL byte" if raise_limit else "more than the 256 MiB") in r.stderr, r.stderr
    assert int(peak) < 500 * 2 ** 20


def test_csv_field_over_the_row_limit(tmp_path, capsys):
    from ehsa_opt.datasets.bench_format import _read_csv
    p = tmp_path / "t.csv"
    with p.open("w") as fh:
        fh.write("time_s,displacement_m,force_N,voltage_V\n0,0,0,0\n")
        fh.write("1" * 5_000_000 + ",0,0,0\n")
    with pytest.raises(BenchDataError, match=r"t.csv: row 3 is longer than \d+ characters"):
        _read_csv(p, True)


def test_unclear_messages_name_the_file(tmp_path):
    import errno

    from ehsa_opt.physics.params import load_toml
    from ehsa_opt.utils.cli_args import os_error_message
    p = tmp_path / "p.toml"
    p.write_text("x = " + "9" * 5000 + "\n")  # beyond Python's integer-string limit
    with pytest.raises(ParameterError, match=f"{p}: not valid TOML"):
        load_toml(p)
    msg = os_error_message(OSError(errno.EFBIG, "File too large"))
    assert "ulimit -f" in msg and "--out" in msg


def test_scan_counts_rows_of_any_line_end(tmp_path):
    from ehsa_opt.utils.limits import scan_csv
    p = tmp_path / "cr.csv"
    p.write_bytes(b"time_s,x\r" + b"".join(b"%d,1\r" % k for k in range(20000)))
    scan_csv(p, 2, "cr.csv", chunk=4096)  # classic-Mac line ends: rows, not one long line
    p.write_bytes(b"time_s,x\r\n" + b"".join(b"%d,1\r\n" % k for k in range(20000))
                  + b"1" * 5000 + b"\r\n")
    with pytest.raises(ValueError, match="row 20002 is longer"):
        scan_csv(p, 2, "crlf.csv", chunk=4096)
