"""Friction bounds the data support (estimation/bounds.py) and identification feeding
simulate."""

from __future__ import annotations

import json

import numpy as np
import pytest

from ehsa_opt.cli import main
from ehsa_opt.datasets.friction_source import load_friction_sets
from ehsa_opt.datasets.synthetic import SyntheticSpec, write_synthetic
from ehsa_opt.estimation.bounds import (
    campaign_low_m_per_s,
    FrictionBounds,
    fit_envelope,
    friction_bounds,
    identification_dict,
    identification_json,
    velocity_grid,
)
from ehsa_opt.estimation.identify_result import IdentificationReport
from ehsa_opt.utils.io import json_safe
from ehsa_opt.estimation.identify import identify
from ehsa_opt.physics.friction import rod_friction_N
from ehsa_opt.physics.params import FrictionParams, load_toml

#: Three tests spread over the velocity range (peak 0.05, 0.19, 0.33 m/s), clean data.
SPEC = SyntheticSpec(frequencies_hz=(0.5, 2.0, 3.5), loads_ohm=(47.0,), seed=11)


@pytest.fixture(scope="module")
def clean(tmp_path_factory):
    d = write_synthetic(tmp_path_factory.mktemp("b") / "clean", SPEC)
    rep = identify(d, starts=1, seed=0)
    truth = FrictionParams(**load_toml(d / "truth.toml")["friction"])
    return d, rep, truth


def test_sets_bracket_the_truth_within_25_percent(clean) -> None:
    _, rep, truth = clean
    fb = friction_bounds(rep)
    r = fb.lead_m_per_rad
    v = np.linspace(0.02, 0.3, 57)
    t = np.asarray(rod_friction_N(v, truth, r))
    lo = np.asarray(rod_friction_N(v, fb.sets["min"], r))
    hi = np.asarray(rod_friction_N(v, fb.sets["max"], r))
    assert np.all(lo <= t) and np.all(hi >= t)
    assert np.all(lo >= 0.75 * t) and np.all(hi <= 1.25 * t)
    # the sets realise the envelope (where the data reach): at/below the lower, at/above
    # the upper curve; beyond the data the envelope is not defined
    m = np.isfinite(fb.lower_N)
    assert m.any() and not m.all() and fb.velocity_m_per_s[-1] == pytest.approx(3.0)
    assert np.all(fb.sets_rod_N["min"][m] <= fb.lower_N[m] + 1e-6)
    assert np.all(fb.sets_rod_N["max"][m] >= fb.upper_N[m] - 1e-6)
    # ordered at every velocity of 0-3 m/s (by construction: also off the grid)
    vv = np.concatenate([np.geomspace(1e-6, 1e-2, 300), np.linspace(1e-2, 3.0, 600)])
    rods = [np.asarray(rod_friction_N(vv, fb.sets[c], r)) for c in ("min", "best", "max")]
    assert np.all(rods[0] <= rods[1] + 1e-9) and np.all(rods[1] <= rods[2] + 1e-9)
    # beyond the data the band widens and (clean data) holds the truth up to 1.5 m/s
    vo = np.linspace(fb.data_range_m_per_s[1], 1.5, 40)[1:]
    to = np.asarray(rod_friction_N(vo, truth, r))
    inside = (np.asarray(rod_friction_N(vo, fb.sets["min"], r)) <= to) & (
        to <= np.asarray(rod_friction_N(vo, fb.sets["max"], r)))
    assert inside.mean() >= 0.9
    width = fb.margin_band_N[1] - fb.margin_band_N[0]
    assert width[-1] > 2.0 * width[np.flatnonzero(m)[-1]]
    # the paper's per-parameter sets are much wider than what the data support
    pmin = np.asarray(rod_friction_N(v, fb.paper_sets["min"], r))
    pmax = np.asarray(rod_friction_N(v, fb.paper_sets["max"], r))
    assert np.mean(pmax - pmin) > 2.0 * np.mean(hi - lo)


def test_identification_json_round_trip(clean, tmp_path) -> None:
    _, rep, _ = clean
    text = identification_json(rep)
    doc = json.loads(text)
    assert doc == json_safe(identification_dict(rep))
    env = doc["friction_envelope"]
    assert len(env["velocity_m_per_s"]) == len(env["lower_N"]) == len(env["upper_N"])
    rng = doc["velocity_range"]
    lo, hi = rng["campaign_m_per_s"]
    assert hi == pytest.approx(2 * np.pi * 3.5 * 0.015, rel=1e-6) and 0 < lo < hi
    assert set(rng["tests_peak_m_per_s"]) == {t["file"] for t in doc["tests"]}
    assert env["identified_range_m_per_s"] == [lo, hi]
    band = env["extrapolation_band"]
    assert len(band["margin_low_N"]) == len(env["velocity_m_per_s"])
    assert band["law"]["n_effective"] < band["law"]["n_samples"]
    assert "paper's method" in env["paper_method"]["description"]
    p = tmp_path / "identification.json"
    p.write_text(json.dumps(doc))
    sets = load_friction_sets(p)
    fb = friction_bounds(rep)
    for case in ("min", "best", "max"):
        assert sets[case] == fb.sets[case]
    # the file reloads into results one can inspect and plot: the same report and bounds
    back = IdentificationReport.from_json(text)
    assert back.summary() == rep.summary()
    assert [f.parameters for f in back.fits] == [f.parameters for f in rep.fits]
    assert back.fits[0].history["objective"] == pytest.approx(rep.fits[0].history["objective"])
    assert back.to_dict() == rep.to_dict()
    assert sorted(back.figures()) == sorted(rep.figures())
    fb2 = FrictionBounds.from_json(text)
    assert json.loads(fb2.to_json()) == json.loads(fb.to_json())
    assert fb2.ordered() and len(fb2.plot().axes) == 2
    with pytest.raises(ValueError, match="friction_envelope"):
        FrictionBounds.from_dict({"tests": []})


def test_campaign_range_starts_where_a_test_covers_by_its_protocol() -> None:
    # (lowest resolved speed, peak) per test: a sine resolves from 0 and covers from 10 %
    # of its peak; a constant-velocity stroke holds its plateau speed and covers from it
    sines = np.array([[0.0, 0.05], [0.0, 0.33]])
    strokes = np.array([[0.029, 0.031], [0.098, 0.102], [0.39, 0.41]])
    assert campaign_low_m_per_s(sines) == pytest.approx(0.005)
    assert campaign_low_m_per_s(strokes) == pytest.approx(0.029)
    assert campaign_low_m_per_s(np.vstack([sines, strokes])) == pytest.approx(0.005)
    assert campaign_low_m_per_s(np.array([[0.0, 0.002]])) == pytest.approx(1e-3)


def test_fit_envelope_follows_a_simscape_curve_and_refuses_bad_input() -> None:
    r = 5e-3 / (2 * np.pi)
    truth = FrictionParams(60, 40, 0.01, 150, 0.02, 0.015, 1.0, 3e-5)
    v = velocity_grid(0.3)
    target = np.asarray(rod_friction_N(v, truth, r))
    fr = fit_envelope(target, v, truth, r, "fit")
    assert np.max(np.abs(np.asarray(rod_friction_N(v, fr, r)) / target - 1)) < 0.02
    below = fit_envelope(target, v, truth, r, "below")
    assert np.all(np.asarray(rod_friction_N(v, below, r)) <= target + 1e-6)
    with pytest.raises(ValueError, match="side"):
        fit_envelope(target, v, truth, r, "sideways")
    with pytest.raises(ValueError, match="v_max"):
        velocity_grid(0.0)


def test_identify_then_simulate_from_equals_typed_values(clean, tmp_path, capsys) -> None:
    d, _, _ = clean
    out = tmp_path / "out"
    assert main(["identify", str(d), "--out", str(out), "--starts", "1"]) == 0
    text = capsys.readouterr().out
    assert "paper min" in text and "best" in text
    ident = out / "identification.json"
    sets = load_friction_sets(ident)
    road = '[road]\niso_class = "C"\nspeed_km_per_h = 60.0\nlength_m = 60.0\nseed = 3\n'
    head = 'preset = "passenger_car"\n[harvester]\nload_ohm = 47.0\n'
    p_from = tmp_path / "from.toml"
    p_from.write_text(head + '[friction]\nfrom = "out/identification.json"\ncase = "max"\n'
                      + road)
    p_typed = tmp_path / "typed.toml"
    p_typed.write_text(head + "[friction]\n" + "".join(
        f"{k} = {v!r}\n" for k, v in sets["max"].as_dict().items()) + road)
    p_none = tmp_path / "none.toml"
    p_none.write_text(head + road)
    metrics = []
    for args in (["simulate", str(p_from), "--json"], ["simulate", str(p_typed), "--json"],
                 ["simulate", str(p_none), "--json", "--friction", f"{ident}:max"]):
        assert main(args) == 0
        m = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
        metrics.append({k: v for k, v in m.items() if k != "wall_s"})
    assert metrics[0] == metrics[1] == metrics[2]
    assert metrics[0]["frictionless"] is False
    # a sweep takes its cases from the same file
    sw = tmp_path / "sweep.toml"
    sw.write_text(head + '[road]\niso_class = "C"\nlength_m = 60.0\nseed = 3\n'
                  '[sweep]\nspeed_km_per_h = [60.0]\nfriction = ["min", "max"]\n'
                  'friction_from = "out/identification.json"\n')
    assert main(["sweep", str(sw), "--out", str(tmp_path / "sw")]) == 0
    rows = (tmp_path / "sw" / "sweep.csv").read_text().splitlines()
    header = rows[0].split(",")
    pw = {r.split(",")[header.index("friction")]: float(r.split(",")[header.index("power_W")])
          for r in rows[1:]}
    assert pw["max"] == pytest.approx(metrics[0]["power_W"], rel=1e-9)
    capsys.readouterr()
    assert main(["sweep", str(sw), "--out", str(tmp_path / "sw2"), "--friction",
                 f"{ident}:max"]) == 2
    assert "give the file only" in capsys.readouterr().err


def test_small_things_version_names_rated_limits(tmp_path, capsys) -> None:
    from ehsa_opt.datasets.problem_file import load_problem
    from ehsa_opt.design.config import load_design_config
    from ehsa_opt.physics.params import ParameterError
    from ehsa_opt.utils.version import __version__
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0 and __version__ in capsys.readouterr().out
    assert load_design_config("paper_design").path.endswith("paper_design.toml")
    assert load_problem("quarter_car_class_c").friction is not None
    with pytest.raises(ParameterError, match="shipped: .*paper_design"):
        load_problem("no_such_problem")
    p = tmp_path / "rated.toml"
    p.write_text('preset = "passenger_car"\n[harvester]\nload_ohm = 47.0\n[road]\n'
                 'iso_class = "C"\nspeed_km_per_h = 80.0\nlength_m = 60.0\n'
                 '[simulation]\nrated_voltage_V = 1.0\n')
    assert main(["simulate", str(p), "--json"]) == 0
    cap = capsys.readouterr()
    m = json.loads(cap.out.strip().splitlines()[-1])
    # load power R_e i^2: peak voltage and current follow from the peak power exactly
    assert m["peak_terminal_voltage_V"] == pytest.approx((m["peak_power_W"] * 47.0) ** 0.5)
    assert m["peak_current_A"] * 47.0 == pytest.approx(m["peak_terminal_voltage_V"])
    assert "exceeds the rated 1 V" in cap.err
    p.write_text(p.read_text().replace("rated_voltage_V = 1.0", "rated_voltage_V = -1"))
    assert main(["simulate", str(p)]) == 2
    assert "rated_voltage_V" in capsys.readouterr().err


def test_lugre_sets_carry_the_joint_fits_bristle_else_the_median() -> None:
    from types import SimpleNamespace as NS

    from ehsa_opt.estimation.bounds import presliding_law
    fits = [(None, NS(parameters={"presliding_stiffness_N_per_m": s,
                                  "presliding_damping_Ns_per_m": d}))
            for s, d in ((1e6, 100.0), (3e6, 300.0), (2e6, 900.0))]
    joint = NS(success=True, parameters={"presliding_stiffness_N_per_m": 5e5,
                                         "presliding_damping_Ns_per_m": 50.0})
    assert presliding_law(NS(friction_law="static", joint=joint), fits) == {}
    assert presliding_law(NS(friction_law="lugre", joint=joint), fits) == {
        "presliding_stiffness_N_per_m": 5e5, "presliding_damping_Ns_per_m": 50.0}
    failed = NS(success=False, parameters=joint.parameters)
    assert presliding_law(NS(friction_law="lugre", joint=failed), fits) == {
        "presliding_stiffness_N_per_m": 2e6, "presliding_damping_Ns_per_m": 300.0}
