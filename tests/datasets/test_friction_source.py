"""Friction from an identification result (datasets/friction_source.py)."""

from __future__ import annotations

import json

import pytest

from ehsa_opt.datasets.friction_source import (load_friction, load_friction_sets,
                                               parse_friction_spec)
from ehsa_opt.datasets.problem_file import load_problem
from ehsa_opt.physics.params import FrictionParams, ParameterError

SETS = {
    "min": {"nut_breakaway_N": 40.0, "nut_coulomb_N": 30.0, "nut_viscous_Ns_per_m": 100.0},
    "best": {"nut_breakaway_N": 60.0, "nut_coulomb_N": 45.0, "nut_viscous_Ns_per_m": 150.0,
             "bearing_coulomb_Nm": 0.01, "bearing_breakaway_Nm": 0.012},
    "max": {"nut_breakaway_N": 80.0, "nut_coulomb_N": 60.0, "nut_viscous_Ns_per_m": 200.0,
            "bearing_coulomb_Nm": 0.012, "bearing_breakaway_Nm": 0.015},
}  # ordered: min <= best <= max in rod friction at every velocity


@pytest.fixture()
def ident(tmp_path):
    # identification.json carries complete sets (all eight parameters by name)
    full = {c: FrictionParams(**v).as_dict() for c, v in SETS.items()}
    path = tmp_path / "identification.json"
    path.write_text(json.dumps({"tests": [], "friction_sets": {**full, "method": "envelope"}}))
    return path


def test_sets_load_by_case(ident) -> None:
    sets = load_friction_sets(ident)
    assert sets["max"].nut_coulomb_N == 60.0
    assert sets["best"].bearing_coulomb_Nm == 0.01
    assert load_friction(f"{ident}:min") == FrictionParams(**SETS["min"])
    assert load_friction(ident) == FrictionParams(**SETS["best"])  # default case


def test_spec_parsing_and_refusals(ident, tmp_path) -> None:
    assert parse_friction_spec(f"{ident}:max") == (ident, "max")
    with pytest.raises(ParameterError, match="unknown case 'worst'"):
        parse_friction_spec("x.json:worst")
    with pytest.raises(ParameterError, match="ehsa-opt identify"):
        load_friction(tmp_path / "missing.json")
    old = tmp_path / "old.json"
    old.write_text(json.dumps({"tests": [], "bounds": {}}))
    with pytest.raises(ParameterError, match="no 'friction_sets'.*re-run"):
        load_friction(old)


def _problem(tmp_path, friction_toml: str):
    p = tmp_path / "p.toml"
    p.write_text('preset = "passenger_car"\n' + friction_toml
                 + '[road]\niso_class = "C"\nspeed_km_per_h = 50\nlength_m = 100\n')
    return load_problem(p)


def test_problem_file_from_equals_typed_values(ident, tmp_path) -> None:
    a = _problem(tmp_path, f'[friction]\nfrom = "{ident.name}"\ncase = "max"\n')
    typed = "".join(f"{k} = {v}\n" for k, v in SETS["max"].items())
    b = _problem(tmp_path, "[friction]\n" + typed)
    assert a.friction == b.friction == FrictionParams(**SETS["max"])
    with pytest.raises(ParameterError, match=r"p.toml \[friction\].*only 'case'"):
        _problem(tmp_path, f'[friction]\nfrom = "{ident.name}"\nnut_coulomb_N = 3\n')
