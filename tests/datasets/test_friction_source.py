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


LUGRE = {"friction_law": "lugre", "presliding_stiffness_N_per_m": 2.5e6,
         "presliding_damping_Ns_per_m": 400.0}


def _write(tmp_path, sets, name="identification.json"):
    path = tmp_path / name
    path.write_text(json.dumps({"tests": [], "friction_sets": {**sets, "method": "data"}}))
    return path


def _lugre_sets():
    return {c: {**FrictionParams(**v).as_dict(), **LUGRE} for c, v in SETS.items()}


def test_lugre_sets_round_trip_through_the_file(tmp_path) -> None:
    from ehsa_opt.datasets.identification_file import FrictionSets
    path = _write(tmp_path, _lugre_sets())
    sets = load_friction_sets(path)
    for case, fr in sets.items():
        assert fr.friction_law == "lugre" and not fr.is_static
        assert fr.presliding_stiffness_N_per_m == 2.5e6
        assert fr.presliding_damping_Ns_per_m == 400.0
        assert fr.as_dict() == FrictionParams(**SETS[case]).as_dict()
    fs = FrictionSets(sets["min"], sets["best"], sets["max"], "data")
    again = FrictionSets.from_dict(json.loads(json.dumps(fs.to_dict())))
    assert again == fs and again.friction_law == "lugre"
    # a static set is written exactly as before the law was stored
    static = FrictionSets(*(FrictionParams(**SETS[c]) for c in ("min", "best", "max")), "data")
    assert set(static.to_dict()["best"]) == set(FrictionParams().as_dict())


def test_sets_without_a_law_load_as_the_static_law(ident) -> None:
    sets = load_friction_sets(ident)
    assert all(fr.friction_law == "static" and fr.is_static for fr in sets.values())
    assert all(fr.presliding_stiffness_N_per_m is None for fr in sets.values())


@pytest.mark.parametrize("change, message", [
    ({"presliding_stifness_N_per_m": 1e6}, r"best: unknown key 'presliding_stifness_N_per_m'; "
                                           r"did you mean 'presliding_stiffness_N_per_m'"),
    ({"friction_law": "gms"}, r"best: friction_law = 'gms' is not a friction law"),
    ({"presliding_damping_Ns_per_m": None}, r"best.*needs presliding_damping_Ns_per_m"),
    ({"presliding_stiffness_N_per_m": "1e6"}, r"best: presliding_stiffness_N_per_m = '1e6' "
                                              r"is not a finite number"),
    ({"presliding_stiffness_N_per_m": -5.0}, r"best.*presliding_stiffness_N_per_m.*must be > 0"),
    ({"friction_law": "static"}, r"best.*belong\(s\) to the LuGre law"),
])
def test_bad_law_keys_are_refused_naming_file_and_key(tmp_path, change, message) -> None:
    sets = _lugre_sets()
    sets["best"] = {k: v for k, v in {**sets["best"], **change}.items() if v is not None}
    path = _write(tmp_path, sets)
    before = path.read_bytes()
    with pytest.raises(ParameterError, match=message) as err:
        load_friction_sets(path)
    assert str(path) in str(err.value)
    assert path.read_bytes() == before


def test_cases_under_different_laws_are_refused(tmp_path) -> None:
    sets = _lugre_sets()
    sets["min"] = FrictionParams(**SETS["min"]).as_dict()
    with pytest.raises(ParameterError, match=r"different friction laws \(min static, best "
                                             r"lugre, max lugre\)"):
        load_friction_sets(_write(tmp_path, sets))


def test_problem_friction_table_takes_the_law(tmp_path) -> None:
    law = "".join(f'{k} = {json.dumps(v)}\n' for k, v in LUGRE.items())
    cfg = _problem(tmp_path, "[friction]\nnut_coulomb_N = 30.0\nnut_breakaway_N = 40.0\n" + law)
    assert cfg.friction.friction_law == "lugre"
    assert cfg.friction.presliding_stiffness_N_per_m == 2.5e6
