"""Bench data format: writer + strict loader, and every bad input of the Foundation issue."""

import shutil
from pathlib import Path

import numpy as np
import pytest

from ehsa_opt.datasets.bench_format import BenchDataError, BenchTest, load_bench, write_bench
from ehsa_opt.datasets.embedded import embedded_data_dir
from ehsa_opt.datasets.synthetic import SyntheticSpec, generate_bench_tests, write_synthetic


@pytest.fixture(scope="module")
def small_dir(tmp_path_factory):
    spec = SyntheticSpec(frequencies_hz=(1.0, 2.0), loads_ohm=(47.0,), seed=3)
    out = tmp_path_factory.mktemp("bench") / "small"
    write_synthetic(out, spec, command="test")
    return out


@pytest.fixture
def bad(small_dir, tmp_path):
    """A fresh, valid copy to break."""
    d = tmp_path / "bad"
    shutil.copytree(small_dir, d)
    return d


def _edit_csv(d: Path, fn):
    p = d / "f1Hz_Re47.csv"
    lines = p.read_text().splitlines()
    p.write_text("\n".join(fn(lines)) + "\n")


def test_roundtrip_and_seeded(small_dir, tmp_path):
    data = load_bench(small_dir)
    assert len(data) == 2 and data.has_generator
    t = data.tests[0]
    assert t.frequency_hz == 1.0 and t.load_ohm == 47.0 and t.amplitude_m == 0.015
    assert abs(np.max(np.abs(t.displacement_m)) - 0.015) < 1e-4
    # same seed, same data; another seed, other noise
    spec = SyntheticSpec(frequencies_hz=(1.0, 2.0), loads_ohm=(47.0,), seed=3)
    again = generate_bench_tests(spec)
    np.testing.assert_allclose(again[0].force_N, t.force_N, rtol=0, atol=1e-6)
    other = generate_bench_tests(SyntheticSpec(frequencies_hz=(1.0,), loads_ohm=(47.0,), seed=4))
    assert np.max(np.abs(other[0].force_N - t.force_N)) > 0.5


def test_embedded_data_sets_load():
    assert len(load_bench(embedded_data_dir("bench_prototype"))) == 21
    emps = load_bench(embedded_data_dir("emps"))
    assert not emps.has_generator and emps.tests[0].voltage_V is None
    assert emps.tests[0].n_samples > 24000
    assert len(load_bench(embedded_data_dir("emps/validation"))) == 1


def test_nan(bad):
    _edit_csv(bad, lambda L: L[:10] + [L[10].replace(L[10].split(",")[2], "nan", 1)] + L[11:])
    with pytest.raises(BenchDataError, match=r"f1Hz_Re47.csv: row 11, column 'force_N'.*not finite"):
        load_bench(bad)


def test_inf(bad):
    _edit_csv(bad, lambda L: L[:5] + [",".join(L[5].split(",")[:3] + ["inf"])] + L[6:])
    with pytest.raises(BenchDataError, match=r"row 6, column 'voltage_V'.*not finite"):
        load_bench(bad)


def test_missing_column(bad):
    _edit_csv(bad, lambda L: [",".join(r.split(",")[:3]) for r in L])
    with pytest.raises(BenchDataError, match=r"f1Hz_Re47.csv: row 1 \(header\): missing column "
                                             r"'voltage_V'"):
        load_bench(bad)


def test_renamed_column(bad):
    _edit_csv(bad, lambda L: [L[0].replace("force_N", "force_kN")] + L[1:])
    with pytest.raises(BenchDataError, match=r"missing column 'force_N' \(found 'force_kN': "
                                             r"rename it to 'force_N'\)"):
        load_bench(bad)


def test_non_increasing_time(bad):
    def swap(L):
        L[20], L[21] = L[21], L[20]
        return L
    _edit_csv(bad, swap)
    with pytest.raises(BenchDataError, match=r"f1Hz_Re47.csv: row 22: time_s .* does not increase"):
        load_bench(bad)


def test_truncated_last_row(bad):
    _edit_csv(bad, lambda L: L[:-1] + [L[-1][: len(L[-1]) // 3]])
    with pytest.raises(BenchDataError, match=r"f1Hz_Re47.csv: last row \d+ has \d fields.*truncated"):
        load_bench(bad)


def test_missing_file(bad):
    (bad / "f2Hz_Re47.csv").unlink()
    with pytest.raises(BenchDataError, match=r"f2Hz_Re47.csv: file listed in bench.toml does not "
                                             r"exist"):
        load_bench(bad)


def test_unknown_key(bad):
    p = bad / "bench.toml"
    p.write_text(p.read_text().replace("load_ohm", "load_ohms", 1))
    with pytest.raises(BenchDataError, match=r"bench.toml \[\[test\]\] #1.*unknown key "
                                             r"'load_ohms'; did you mean 'load_ohm'\?"):
        load_bench(bad)


def test_unknown_harvester_key(bad):
    p = bad / "bench.toml"
    p.write_text("[harvester]\nlead_mm_per_rv = 5.0\n\n" + p.read_text())
    with pytest.raises(BenchDataError, match=r"did you mean 'lead_mm_per_rev'"):
        load_bench(bad)


@pytest.mark.parametrize("key,value", [("load_ohm", "-47.0"), ("load_ohm", "0.0"),
                                       ("frequency_hz", "0.0"), ("frequency_hz", "-1.0"),
                                       ("amplitude_m", "-0.015"), ("amplitude_m", "0.0")])
def test_non_positive_values(bad, key, value):
    p = bad / "bench.toml"
    text = p.read_text()
    import re
    text = re.sub(rf"{key} = [0-9.e-]+", f"{key} = {value}", text, count=1)
    p.write_text(text)
    with pytest.raises(BenchDataError, match=rf"'{key}' = .* must be positive"):
        load_bench(bad)


def test_amplitude_unit_slip(bad):
    p = bad / "bench.toml"
    p.write_text(p.read_text().replace("amplitude_m = 0.015", "amplitude_m = 15.0", 1))
    with pytest.raises(BenchDataError, match=r"amplitude_m' = 15 is out of range.*15 mm is 0.015"):
        load_bench(bad)


def test_displacement_in_mm(bad):
    def mm(L):
        out = [L[0]]
        for r in L[1:]:
            f = r.split(",")
            f[1] = repr(float(f[1]) * 1e3 + 100.0)
            out.append(",".join(f))
        return out
    _edit_csv(bad, mm)
    with pytest.raises(BenchDataError, match=r"displacement_m.*is it in mm"):
        load_bench(bad)


def test_empty_file(bad):
    (bad / "f1Hz_Re47.csv").write_text("")
    with pytest.raises(BenchDataError, match=r"f1Hz_Re47.csv: file is empty"):
        load_bench(bad)


def test_header_only(bad):
    (bad / "f1Hz_Re47.csv").write_text("time_s,displacement_m,force_N,voltage_V\n")
    with pytest.raises(BenchDataError, match=r"no data rows"):
        load_bench(bad)


def test_missing_bench_toml(bad):
    (bad / "bench.toml").unlink()
    with pytest.raises(BenchDataError, match=r"bench.toml: not found"):
        load_bench(bad)


def test_writer_refuses_non_empty_and_leaves_nothing_half_written(small_dir, tmp_path):
    data = load_bench(small_dir)
    with pytest.raises(FileExistsError, match="not empty"):
        write_bench(small_dir, data.tests)
    # a failing write leaves neither the target nor temporaries behind
    broken = BenchTest(file="x.csv", frequency_hz=1.0, amplitude_m=0.015, load_ohm=1.0,
                       excitation="sine", time_s=np.arange(3.0), displacement_m=None,
                       force_N=np.zeros(3), voltage_V=np.zeros(3))
    target = tmp_path / "new"
    with pytest.raises(Exception):
        write_bench(target, [data.tests[0], broken])
    assert not target.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".new")]


def test_written_directory_is_spec_format(small_dir, tmp_path):
    # a directory written by hand to the SPEC format (minimal keys) is accepted
    d = tmp_path / "hand"
    d.mkdir()
    from ehsa_opt.physics.params import HarvesterParams
    h = HarvesterParams()
    t = np.linspace(0, 1, 50)
    w = 2 * np.pi
    x, v = 0.015 * np.sin(w * t), 0.015 * w * np.cos(w * t)
    # signals the harvester of bench.toml can produce (the physics checks look at them)
    force = -h.equivalent_mass_kg() * w ** 2 * x + h.equivalent_damping_Ns_per_m(w, 47.0) * v
    volt = h.voltage_constant_Vs_per_rad * v / h.lead_m_per_rad * 47.0 / 53.6
    rows = "\n".join(f"{a},{b},{c},{e}" for a, b, c, e in zip(t, x, force, volt))
    (d / "a.csv").write_text("time_s,displacement_m,force_N,voltage_V\n" + rows + "\n")
    (d / "bench.toml").write_text('[harvester]\nlead_mm_per_rev = 5.0\n[[test]]\nfile = "a.csv"\n'
                                  'frequency_hz = 1.0\namplitude_m = 0.015\nload_ohm = 47.0\n')
    assert len(load_bench(d)) == 1
