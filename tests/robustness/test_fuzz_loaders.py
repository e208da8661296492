"""Property-based fuzzing of every loader (hypothesis): generated malformed inputs give
exit status 2 and a message through the CLI — never a traceback.

Two kinds of input per loader: the bytes of a valid file with random edits (inserted,
deleted or replaced bytes, truncation, a NUL, a byte-order mark, a deep nesting, an
over-long field), and the parsed document of a valid file with a random sub-tree
replaced by a random value (wrong types, missing tables, NaN, huge numbers).  A valid
input may come out (exit 0); then the loader accepted it and the heavy work after
loading is skipped.  The default suite runs a bounded number of examples; the ``slow``
form runs many more.
"""

from __future__ import annotations

import contextlib
import io
import json
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
import tomli_w
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ehsa_opt.cli import main
from ehsa_opt.datasets.synthetic import SyntheticSpec, write_synthetic
from tests.paths import ROOT

FAST = settings(max_examples=12, deadline=None, derandomize=True, database=None,
                suppress_health_check=list(HealthCheck))
LONG = settings(max_examples=40, deadline=None, derandomize=True, database=None,
                suppress_health_check=list(HealthCheck))


class Loaded(Exception):
    """Raised by a stub in place of the heavy work after a successful load."""


# ------------------------------------------------------------------ generated inputs
EDITS = st.lists(st.tuples(
    st.sampled_from(["insert", "delete", "replace", "truncate", "nul", "bom", "nest",
                     "long", "newline", "quote"]),
    st.floats(0.0, 1.0), st.binary(min_size=1, max_size=6)), min_size=1, max_size=4)


def edited(valid: bytes, edits) -> bytes:
    b = bytearray(valid)
    for op, where, blob in edits:
        k = int(where * len(b))
        if op == "insert":
            b[k:k] = blob
        elif op == "delete":
            del b[k:k + len(blob)]
        elif op == "replace":
            b[k:k + len(blob)] = blob
        elif op == "truncate":
            del b[k:]
        elif op == "nul":
            b[k:k] = b"\x00"
        elif op == "bom":
            b[0:0] = b"\xef\xbb\xbf"
        elif op == "nest":
            b[k:k] = b"[" * 5000 + b"]" * 5000
        elif op == "long":
            b[k:k] = b"9" * 200_000
        elif op == "newline":
            b[k:k] = b"\n"
        else:
            b[k:k] = b'"'
    return bytes(b)


LEAVES = (st.none() | st.booleans() | st.integers(-10**30, 10**30)
          | st.floats(allow_nan=True, allow_infinity=True) | st.text(max_size=12)
          | st.sampled_from(["", "C", "min", "../../etc/passwd", "/abs.csv", "a\x00b"]))
VALUES = st.recursive(LEAVES, lambda c: st.lists(c, max_size=3)
                      | st.dictionaries(st.text(max_size=8), c, max_size=3), max_leaves=6)


def paths(doc, prefix=()):
    yield prefix
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for k, v in enumerate(doc):
            yield from paths(v, prefix + (k,))


def replaced(doc, choice: float, value, drop: bool):
    """``doc`` with the sub-tree at one of its paths replaced by ``value`` (or dropped)."""
    doc = json.loads(json.dumps(doc))
    all_paths = [p for p in paths(doc) if p]
    if not all_paths:
        return value
    path = all_paths[int(choice * (len(all_paths) - 1))]
    node = doc
    for k in path[:-1]:
        node = node[k]
    if drop:
        del node[path[-1]]
    else:
        node[path[-1]] = value
    return doc


def toml_bytes(doc) -> bytes | None:
    if not isinstance(doc, dict):
        return None
    try:
        return tomli_w.dumps(doc).encode()
    except (TypeError, ValueError):  # None or mixed values TOML cannot hold
        return None


# ------------------------------------------------------------------ the CLI
def cli(capsys, *argv) -> tuple[int, str]:
    """Run the CLI; the loader's verdict: 0 (accepted) or 2 (refused with a message)."""
    try:
        rc = main([str(a) for a in argv])
    except Loaded:
        rc = 0
    except SystemExit as exc:
        rc = exc.code
    err = capsys.readouterr().err
    assert rc in (0, 2), (rc, err)
    if rc == 2:
        assert err.startswith("error: ") or "error:" in err, err
        assert "Traceback" not in err and len(err) < 20_000
    return rc, err


@pytest.fixture(scope="module")
def valid_bench(tmp_path_factory):
    out = tmp_path_factory.mktemp("fuzz") / "bench"
    write_synthetic(out, SyntheticSpec(frequencies_hz=(1.0, 2.0), loads_ohm=(47.0,), seed=3),
                    command="fuzz")
    return out


@pytest.fixture
def stub_work(monkeypatch):
    """Stop right after loading: no simulation, optimisation or discrepancy run."""
    import ehsa_opt.design.optimize as opt
    import ehsa_opt.estimation.discrepancy as disc
    import ehsa_opt.vehicle.simulate as sim
    from ehsa_opt.vehicle.road import road_profile

    def simulate(vehicle, harvester=None, friction=None, road=None, *, sample_rate_hz=1000.0,
                 base_dir=None, **kw):
        if getattr(road, "profile_csv", None) is not None:
            road_profile(road, sample_rate_hz, base_dir)  # the profile loader runs
        raise Loaded

    def stop(*a, **k):
        raise Loaded
    monkeypatch.setattr(sim, "simulate_quarter_car", simulate)
    monkeypatch.setattr(opt, "run_nsga2", stop)
    monkeypatch.setattr(disc, "run_discrepancy", stop)


@contextlib.contextmanager
def workdir():
    d = Path(tempfile.mkdtemp(prefix="fuzz_"))
    try:
        yield d
    finally:
        shutil.rmtree(d, ignore_errors=True)


# ------------------------------------------------------------------ one check per loader
def check_bench_toml(capsys, valid_bench, data: bytes) -> None:
    with workdir() as d:
        shutil.copytree(valid_bench, d / "b")
        (d / "b" / "bench.toml").write_bytes(data)
        cli(capsys, "bench", "check", d / "b")


def check_bench_csv(capsys, valid_bench, data: bytes) -> None:
    with workdir() as d:
        shutil.copytree(valid_bench, d / "b")
        (d / "b" / "f1Hz_Re47.csv").write_bytes(data)
        cli(capsys, "bench", "check", d / "b")


PROBLEM = (ROOT / "problems/quarter_car_class_c.toml").read_bytes()
ROAD = b"distance_m,elevation_m\n" + b"".join(
    f"{k},{0.01 * np.sin(k / 7):.5f}\n".encode() for k in range(400))


def check_problem(capsys, data: bytes) -> None:
    with workdir() as d:
        (d / "road.csv").write_bytes(ROAD)
        (d / "p.toml").write_bytes(data)
        cli(capsys, "simulate", d / "p.toml")


def check_profile(capsys, data: bytes) -> None:
    with workdir() as d:
        (d / "road.csv").write_bytes(data)
        (d / "p.toml").write_text('[road]\nprofile_csv = "road.csv"\nspeed_km_per_h = 36.0\n')
        cli(capsys, "simulate", d / "p.toml")


FRICTION = {"nut_breakaway_N": 80.0, "nut_coulomb_N": 60.0,
            "nut_breakaway_velocity_m_per_s": 0.02, "nut_viscous_Ns_per_m": 500.0,
            "bearing_breakaway_Nm": 0.01, "bearing_coulomb_Nm": 0.005,
            "bearing_breakaway_velocity_rad_per_s": 2.0, "bearing_viscous_Nms_per_rad": 1e-4}
IDENT = {"tests": [], "friction_sets": {"min": FRICTION, "best": FRICTION, "max": FRICTION,
                                        "method": "fuzz"}}


def check_identification(capsys, data: bytes) -> None:
    with workdir() as d:
        (d / "identification.json").write_bytes(data)
        cli(capsys, "simulate", ROOT / "problems/quarter_car_class_c.toml", "--friction",
            f"{d / 'identification.json'}:max")


def check_truth(capsys, valid_bench, data: bytes) -> None:
    with workdir() as d:
        shutil.copytree(valid_bench, d / "b")
        (d / "b" / "truth.toml").write_bytes(data)
        cli(capsys, "discrepancy", d / "b", "--out", d / "o")


@pytest.fixture(scope="module")
def valid_checkpoint(tmp_path_factory):
    from ehsa_opt.design import checkpoint as cp
    d = tmp_path_factory.mktemp("fuzz") / "ck"
    main(["optimize", str(ROOT / "problems/paper_design.toml"), "--method", "nsga2", "--pop",
          "8", "--gens", "2", "--stop-after", "1", "--checkpoint", str(d), "--out",
          str(d.parent / "o")])
    with np.load(d / cp.CHECKPOINT_FILE, allow_pickle=False) as z:
        header = json.loads(bytes(z["header"]).decode())
        arrays = {k: z[k] for k in cp._ARRAYS}
    return header, arrays


def check_checkpoint(capsys, header_bytes: bytes, arrays, resign: bool) -> None:
    """A checkpoint whose header was edited; ``resign``: its digest recomputed (a forger)."""
    from ehsa_opt.design import checkpoint as cp
    with workdir() as d:
        ck = d / "ck"
        ck.mkdir()
        if resign:
            try:
                header = json.loads(header_bytes)
                if isinstance(header, dict):
                    header["sha256"] = cp._digest(header, arrays)
                    header_bytes = json.dumps(header).encode()
            except (ValueError, RecursionError, TypeError):
                pass
        buf = io.BytesIO()
        np.savez(buf, header=np.frombuffer(header_bytes, dtype=np.uint8), **arrays)
        (ck / cp.CHECKPOINT_FILE).write_bytes(buf.getvalue())
        cli(capsys, "optimize", ROOT / "problems/paper_design.toml", "--method", "nsga2",
            "--pop", "8", "--gens", "2", "--resume", ck, "--out", d / "o")


def check_cache_entry(data: bytes) -> None:
    """A cache entry is never trusted: any damage means None (recompute), never an error."""
    import hashlib

    from ehsa_opt.pipeline.cache import StepCache, decode, encode
    with workdir() as d:
        lines: list[str] = []
        cache = StepCache(d, lines.append)
        try:  # re-signed, as a forger would
            doc = decode(data.decode())
            if isinstance(doc, dict):
                doc.pop("sha256", None)
                doc["sha256"] = hashlib.sha256(encode(doc).encode()).hexdigest()
                data = encode(doc).encode()
        except (ValueError, UnicodeDecodeError, TypeError):
            pass
        cache.path("data").write_bytes(data)
        payload = cache.load("data", "k")
        assert payload is None or (isinstance(payload, dict)
                                   and isinstance(payload.get("markdown"), str))


def check_emps(capsys, est: bytes, val: bytes) -> None:
    with workdir() as d:
        (d / "src").mkdir()
        (d / "src" / "emps_estimation.csv").write_bytes(est)
        (d / "src" / "emps_validation_pulses.csv").write_bytes(val)
        cli(capsys, "bench", "convert-emps", d / "src", d / "out")


def _emps_text(cols: int) -> bytes:
    t = np.arange(200) * 1e-3
    x = 0.01 * np.sin(2 * np.pi * 2 * t)
    arr = np.column_stack([t, x, x, 0.5 * np.cos(2 * np.pi * 2 * t), 0 * t])[:, :cols]
    head = "time_s,position_m,reference_position_m,control_voltage_V,pulse_N".split(",")
    buf = io.StringIO()
    np.savetxt(buf, arr, delimiter=",", header=",".join(head[:cols]), comments="", fmt="%.6g")
    return buf.getvalue().encode()


EST, VAL = _emps_text(4), _emps_text(5)
CACHE_ENTRY = json.dumps({"format": "ehsa_opt-step-cache/1", "step": "data", "hash": "k",
                          "figures_sha256": {}, "payload": {
                              "markdown": "| a | b |\n|---|---|\n| 1 | 2 |\n", "figures": [],
                              "results": {"x": 1.0}, "seconds": 0.1}}).encode()


# ------------------------------------------------------------------ the properties
def _properties(cfg, tag: str):
    """The fuzz properties under one hypothesis ``settings`` (fast or long)."""
    marks = [pytest.mark.slow] if tag == "long" else []

    def mark(fn):
        for m in marks:
            fn = m(fn)
        return fn

    @mark
    @cfg
    @given(edits=EDITS)
    def bench_toml_bytes(capsys, valid_bench, edits):
        check_bench_toml(capsys, valid_bench,
                         edited((valid_bench / "bench.toml").read_bytes(), edits))

    @mark
    @cfg
    @given(choice=st.floats(0, 1), value=VALUES, drop=st.booleans())
    def bench_toml_tree(capsys, valid_bench, choice, value, drop):
        from ehsa_opt.physics.params import load_toml
        data = toml_bytes(replaced(load_toml(valid_bench / "bench.toml"), choice, value, drop))
        if data is not None:
            check_bench_toml(capsys, valid_bench, data)

    @mark
    @cfg
    @given(edits=EDITS)
    def bench_csv(capsys, valid_bench, edits):
        check_bench_csv(capsys, valid_bench,
                        edited((valid_bench / "f1Hz_Re47.csv").read_bytes(), edits))

    @mark
    @cfg
    @given(edits=EDITS)
    def problem_bytes(capsys, stub_work, edits):
        check_problem(capsys, edited(PROBLEM, edits))

    @mark
    @cfg
    @given(choice=st.floats(0, 1), value=VALUES, drop=st.booleans())
    def problem_tree(capsys, stub_work, choice, value, drop):
        import tomllib
        data = toml_bytes(replaced(tomllib.loads(PROBLEM.decode()), choice, value, drop))
        if data is not None:
            check_problem(capsys, data)

    @mark
    @cfg
    @given(edits=EDITS)
    def profile_csv(capsys, stub_work, edits):
        check_profile(capsys, edited(ROAD, edits))

    @mark
    @cfg
    @given(edits=EDITS)
    def identification_bytes(capsys, stub_work, edits):
        check_identification(capsys, edited(json.dumps(IDENT).encode(), edits))

    @mark
    @cfg
    @given(choice=st.floats(0, 1), value=VALUES, drop=st.booleans())
    def identification_tree(capsys, stub_work, choice, value, drop):
        doc = replaced(IDENT, choice, value, drop)
        check_identification(capsys, json.dumps(doc).encode())

    @mark
    @cfg
    @given(choice=st.floats(0, 1), value=VALUES, drop=st.booleans())
    def truth_tree(capsys, valid_bench, stub_work, choice, value, drop):
        from ehsa_opt.physics.params import load_toml
        data = toml_bytes(replaced(load_toml(valid_bench / "truth.toml"), choice, value, drop))
        if data is not None:
            check_truth(capsys, valid_bench, data)

    @mark
    @cfg
    @given(edits=EDITS)
    def truth_bytes(capsys, valid_bench, stub_work, edits):
        check_truth(capsys, valid_bench, edited((valid_bench / "truth.toml").read_bytes(), edits))

    @mark
    @cfg
    @given(choice=st.floats(0, 1), value=VALUES, drop=st.booleans(), resign=st.booleans())
    def checkpoint_header(capsys, valid_checkpoint, stub_work, choice, value, drop, resign):
        header, arrays = valid_checkpoint
        doc = replaced(header, choice, value, drop)
        check_checkpoint(capsys, json.dumps(doc).encode(), arrays, resign)

    @mark
    @cfg
    @given(edits=EDITS)
    def checkpoint_header_bytes(capsys, valid_checkpoint, stub_work, edits):
        header, arrays = valid_checkpoint
        check_checkpoint(capsys, edited(json.dumps(header).encode(), edits), arrays, False)

    @mark
    @cfg
    @given(edits=EDITS)
    def cache_entry_bytes(edits):
        check_cache_entry(edited(CACHE_ENTRY, edits))

    @mark
    @cfg
    @given(choice=st.floats(0, 1), value=VALUES, drop=st.booleans())
    def cache_entry_tree(choice, value, drop):
        doc = replaced(json.loads(CACHE_ENTRY), choice, value, drop)
        try:
            data = json.dumps(doc, allow_nan=False).encode()
        except ValueError:
            return
        check_cache_entry(data)

    @mark
    @cfg
    @given(edits=EDITS, which=st.booleans())
    def emps_source(capsys, edits, which):
        check_emps(capsys, edited(EST, edits) if which else EST,
                   VAL if which else edited(VAL, edits))

    found = dict(locals())
    return {f"test_fuzz_{tag}_{name}": fn for name, fn in found.items()
            if callable(fn) and name not in ("mark", "cfg", "tag", "marks")}


globals().update(_properties(FAST, "fast"))
globals().update(_properties(LONG, "long"))
