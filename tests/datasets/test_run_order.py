"""The run order of a campaign in the bench format: the optional ``run_order`` and
``started_at`` keys parsed, refused with a message naming the file and the key, and
written back by the writer."""

from __future__ import annotations

import datetime as dt
import shutil
import tomllib

import pytest
import tomli_w

from ehsa_opt.cli import main
from ehsa_opt.datasets.bench_format import BenchDataError, load_bench, write_bench
from ehsa_opt.datasets.run_order import run_sequence, start_offsets_s
from ehsa_opt.datasets.synthetic import SyntheticSpec, write_synthetic

FILES = ("f1Hz_Re47.csv", "f2Hz_Re47.csv", "f3Hz_Re47.csv")


@pytest.fixture(scope="module")
def plain(tmp_path_factory):
    out = tmp_path_factory.mktemp("bench") / "plain"
    write_synthetic(out, SyntheticSpec(frequencies_hz=(1.0, 2.0, 3.0), loads_ohm=(47.0,),
                                       seed=3), command="test")
    return out


def _with(plain, tmp_path, keys: dict[str, str]):
    """A copy of ``plain`` whose ``[[test]]`` for each file gets the TOML lines given."""
    d = tmp_path / "d"
    shutil.copytree(plain, d)
    p = d / "bench.toml"
    doc = tomllib.loads(p.read_text())
    for entry in doc["test"]:
        entry.update(tomllib.loads(keys.get(entry["file"], "")))
    p.write_text(tomli_w.dumps(doc))
    return d


def test_run_order_and_start_times_are_loaded(plain, tmp_path):
    d = _with(plain, tmp_path, {
        FILES[0]: "run_order = 3\nstarted_at = 2026-03-02T09:10:00Z",
        FILES[1]: "run_order = 1\nstarted_at = 2026-03-02T09:00:00Z",
        FILES[2]: "run_order = 2\nstarted_at = 2026-03-02T09:04:30.5Z"})
    tests = load_bench(d).tests
    assert [t.run_order for t in tests] == [3, 1, 2]
    assert tests[1].started_at == dt.datetime(2026, 3, 2, 9, 0, tzinfo=dt.timezone.utc)
    assert run_sequence(tests) == [1, 2, 0]
    assert start_offsets_s(tests) == [600.0, 0.0, 270.5]


def test_without_the_keys_nothing_is_stated(plain):
    tests = load_bench(plain).tests
    assert all(t.run_order is None and t.started_at is None for t in tests)
    assert run_sequence(tests) is None and start_offsets_s(tests) is None


def test_time_stamps_alone_give_the_order(plain, tmp_path):
    d = _with(plain, tmp_path, {FILES[0]: "started_at = 2026-03-02T10:00:00",
                                FILES[1]: "started_at = 2026-03-02T09:00:00",
                                FILES[2]: "started_at = 2026-03-02T09:30:00"})
    tests = load_bench(d).tests
    assert run_sequence(tests) == [1, 2, 0]
    assert start_offsets_s(tests) == [3600.0, 0.0, 1800.0]


@pytest.mark.parametrize("keys, message", [
    ({FILES[0]: "run_order = 2", FILES[1]: "run_order = 1", FILES[2]: "run_order = 2"},
     r"bench.toml \[\[test\]\] \(f3Hz_Re47.csv\): 'run_order' = 2 is also that of "
     r"f1Hz_Re47.csv; each test has its own place"),
    ({FILES[0]: "run_order = 1", FILES[2]: "run_order = 2"},
     r"\(f2Hz_Re47.csv\): no 'run_order' while 2 other test\(s\) have one .*give every "
     r"test its 'run_order' or none"),
    ({FILES[0]: "run_order = 1\nstarted_at = 2026-03-02T09:00:00Z",
      FILES[1]: "run_order = 2\nstarted_at = 2026-03-02T09:20:00Z",
      FILES[2]: "run_order = 3\nstarted_at = 2026-03-02T09:10:00Z"},
     r"\(f3Hz_Re47.csv\): 'started_at' = 2026-03-02T09:10:00\+00:00 is not after "
     r"f2Hz_Re47.csv's .*run_order 3 comes after 2: the time stamps must increase"),
    ({FILES[0]: "started_at = 2026-03-02T09:00:00Z", FILES[1]: "started_at = "
      "2026-03-02T09:00:00Z", FILES[2]: "started_at = 2026-03-02T09:05:00Z"},
     r"\(f2Hz_Re47.csv\): 'started_at' .* is not after f1Hz_Re47.csv's .*cannot start at "
     r"the same instant"),
    ({FILES[0]: "started_at = 2026-03-02T09:00:00Z", FILES[1]: "started_at = "
      "2026-03-02T09:01:00", FILES[2]: "started_at = 2026-03-02T09:05:00Z"},
     r"\(f2Hz_Re47.csv\): 'started_at' .* mixes a time stamp without an offset"),
    ({FILES[0]: 'started_at = "2026-03-02T09:00:00Z"'},
     r"#1 \(f1Hz_Re47.csv\): 'started_at' = '2026-03-02T09:00:00Z' must be a TOML "
     r"date-time \(write it without quotes"),
    ({FILES[0]: "started_at = 2026-03-02"},
     r"#1 \(f1Hz_Re47.csv\): 'started_at' = datetime.date\(2026, 3, 2\) must be a TOML "
     r"date-time \(a date and a time of day"),
    ({FILES[1]: "run_order = 0"},
     r"#2 \(f2Hz_Re47.csv\): 'run_order' = 0 must be a whole number >= 1"),
    ({FILES[1]: "run_order = 1.5"},
     r"#2 \(f2Hz_Re47.csv\): 'run_order' = 1.5 must be a whole number >= 1"),
    ({FILES[1]: "run_order = true"},
     r"#2 \(f2Hz_Re47.csv\): 'run_order' = True must be a whole number >= 1"),
], ids=["duplicate-order", "partial", "time-against-order", "same-instant", "mixed-offset",
        "quoted", "date-only", "zero", "fraction", "boolean"])
def test_bad_run_order_is_refused_naming_file_and_key(plain, tmp_path, keys, message):
    d = _with(plain, tmp_path, keys)
    with pytest.raises(BenchDataError, match=message):
        load_bench(d)


def test_bench_check_exits_2_on_a_duplicate_run_order(plain, tmp_path, capsys):
    d = _with(plain, tmp_path, {FILES[0]: "run_order = 1", FILES[1]: "run_order = 1",
                                FILES[2]: "run_order = 2"})
    before = (d / "bench.toml").read_text()
    assert main(["bench", "check", str(d)]) == 2
    err = capsys.readouterr().err
    assert "f2Hz_Re47.csv" in err and "'run_order' = 1" in err
    assert (d / "bench.toml").read_text() == before


def test_round_trip_through_the_writer(plain, tmp_path):
    d = _with(plain, tmp_path, {
        FILES[0]: "run_order = 2\nstarted_at = 2026-03-02T09:10:00.25Z",
        FILES[1]: "run_order = 3\nstarted_at = 2026-03-02T09:20:00Z",
        FILES[2]: "run_order = 1\nstarted_at = 2026-03-02T09:00:00Z"})
    first = load_bench(d)
    out = write_bench(tmp_path / "again", first.tests, harvester=first.harvester)
    again = load_bench(out).tests
    assert [(t.file, t.run_order, t.started_at) for t in again] == \
        [(t.file, t.run_order, t.started_at) for t in first.tests]
    assert again[0].started_at.microsecond == 250000


def test_writer_refuses_a_duplicate_run_order(plain, tmp_path):
    from dataclasses import replace
    tests = [replace(t, run_order=1) for t in load_bench(plain).tests]
    with pytest.raises(ValueError, match=r"'run_order' = 1 is also that of f1Hz_Re47.csv"):
        write_bench(tmp_path / "w", tests)
    assert not (tmp_path / "w").exists()
