"""Property-based fuzzing (hypothesis) of the library's reload paths and of the motor
catalogue and rig readers: generated malformed inputs raise the product's own input error
(:class:`ParameterError` / :class:`BenchDataError`, naming the input) — never another
exception — and what is accepted holds no NaN and no unordered friction sets.

Deterministic (``derandomize=True``) and bounded (a few seconds per property), like
``test_fuzz_loaders.py``, whose generated edits and values these reuse.
"""

from __future__ import annotations

import json
import math
import os

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from ehsa_opt.datasets.bench_format import BenchDataError
from ehsa_opt.design.rig import MAX_PLANNED_SAMPLES, load_rig, planned_samples
from ehsa_opt.estimation.bounds import FrictionBounds
from ehsa_opt.estimation.identify_result import IdentificationReport
from ehsa_opt.physics.friction import rod_friction_N
from ehsa_opt.physics.motor import load_catalogue
from ehsa_opt.physics.params import FRICTION_NAMES, ParameterError
from tests.paths import ROOT
from tests.robustness.test_fuzz_loaders import EDITS, VALUES, edited, replaced, toml_bytes
from tests.robustness.test_received_files import bounds_doc, make_law

#: Each property runs in about a second (the loaders do no heavy work after reading).
FAST = settings(max_examples=int(os.environ.get("EHSA_OPT_FUZZ_EXAMPLES", 60)), deadline=None,
                derandomize=True, database=None, suppress_health_check=list(HealthCheck))
OWN = (ParameterError, BenchDataError)
V = np.concatenate([np.geomspace(1e-6, 1e-2, 30), np.linspace(1e-2, 3.0, 60)])


@pytest.fixture(scope="module")
def good() -> dict:
    return {"data_dir": "/nonexistent/bench", "tests": [], "bounds": {}, "identifiable": {},
            **bounds_doc(make_law())}


def accepted_sets_are_sound(fb: FrictionBounds) -> None:
    rod = {}
    for case in ("min", "best", "max"):
        vals = fb.sets[case].as_array()
        assert all(math.isfinite(x) for x in vals)
        rod[case] = np.asarray(rod_friction_N(V, fb.sets[case], fb.lead_m_per_rad))
    assert np.all(rod["min"] <= rod["best"] + 1e-6) and np.all(rod["best"] <= rod["max"] + 1e-6)
    assert math.isfinite(fb.lead_m_per_rad) and fb.lead_m_per_rad > 0


def reload(text) -> None:
    try:
        fb = FrictionBounds.from_json(text)
    except OWN:
        pass
    else:
        accepted_sets_are_sound(fb)
    try:
        IdentificationReport.from_json(text)
    except OWN:  # the bench data are not there: refused after the validation
        pass


@FAST
@given(edits=EDITS)
def test_fuzz_reload_bytes(good, edits):
    reload(edited(json.dumps(good).encode(), edits))


@FAST
@given(choice=st.floats(0, 1), value=VALUES, drop=st.booleans())
def test_fuzz_reload_tree(good, choice, value, drop):
    doc = replaced(good, choice, value, drop)
    try:
        text = json.dumps(doc, allow_nan=False)
    except ValueError:
        text = json.dumps(doc)  # NaN / Infinity: refused by the strict parser
    reload(text)


NUMBERS = st.floats(allow_nan=True, allow_infinity=True) | st.integers(-10, 10**6)


@FAST
@given(st.lists(st.tuples(st.sampled_from(("min", "best", "max")),
                          st.sampled_from(FRICTION_NAMES), NUMBERS), min_size=1, max_size=6))
def test_fuzz_friction_sets_never_accepted_unordered_or_nan(good, changes):
    doc = json.loads(json.dumps(good))
    for case, name, value in changes:
        doc["friction_sets"][case][name] = value
    try:
        fb = FrictionBounds.from_dict(doc)
    except OWN:
        return
    accepted_sets_are_sound(fb)


CATALOGUE = (ROOT / "ehsa_opt/data/motors/dc_generators.toml").read_bytes()


def catalogue(tmp_path_factory, data: bytes) -> None:
    p = tmp_path_factory.mktemp("cat") / "c.toml"
    p.write_bytes(data)
    try:
        motors = load_catalogue(p)
    except ParameterError:
        return
    for m in motors:
        for x in (m.voltage_constant_Vs_per_rad, m.internal_resistance_ohm, m.inductance_H,
                  m.motor_inertia_gcm2):
            assert math.isfinite(x) and x > 0


@FAST
@given(edits=EDITS)
def test_fuzz_catalogue_bytes(tmp_path_factory, edits):
    catalogue(tmp_path_factory, edited(CATALOGUE, edits))


@FAST
@given(choice=st.floats(0, 1), value=VALUES, drop=st.booleans())
def test_fuzz_catalogue_tree(tmp_path_factory, choice, value, drop):
    import tomllib
    data = toml_bytes(replaced(tomllib.loads(CATALOGUE.decode()), choice, value, drop))
    if data is not None:
        catalogue(tmp_path_factory, data)


RIG = (b"[rig]\nstroke_m = 0.1\npeak_velocity_m_per_s = 1.5\nforce_N = 8000.0\n"
       b"actuator_power_W = 4000.0\nloads_ohm = [15.0, 47.0]\nsample_rate_hz = 1000.0\n"
       b"cycles = 2.0\nreversal_s = 0.05\nmin_frequency_hz = 0.1\nmax_frequency_hz = 20.0\n")


def rig(tmp_path_factory, data: bytes) -> None:
    p = tmp_path_factory.mktemp("rig") / "rig.toml"
    p.write_bytes(data)
    try:
        r = load_rig(p)
    except ParameterError:
        return
    assert planned_samples(r) <= MAX_PLANNED_SAMPLES


@FAST
@given(edits=EDITS)
def test_fuzz_rig_bytes(tmp_path_factory, edits):
    rig(tmp_path_factory, edited(RIG, edits))


@FAST
@given(choice=st.floats(0, 1), value=VALUES | NUMBERS, drop=st.booleans())
def test_fuzz_rig_tree(tmp_path_factory, choice, value, drop):
    import tomllib
    data = toml_bytes(replaced(tomllib.loads(RIG.decode()), choice, value, drop))
    if data is not None:
        rig(tmp_path_factory, data)
