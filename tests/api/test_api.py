"""The scripting API (``import ehsa_opt``): every entry point returns a result in memory
and writes nothing; results save and load back (JSON/CSV); the command line gives the
same numbers as the API on the same inputs; user objectives and constraints; any pymoo
algorithm; a run without a feasible design says so."""

from __future__ import annotations

import json
import logging
import pydoc

import numpy as np
import pytest

import ehsa_opt
from ehsa_opt.cli import main
from tests.paths import ROOT

PAPER = str(ROOT / "problems" / "paper_design.toml")
SWEEP = str(ROOT / "problems" / "sweep_friction.toml")
QUARTER_CAR = str(ROOT / "problems" / "quarter_car_class_c.toml")


def _files(folder):
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*")
                  if p.is_file() and not p.name.startswith("."))  # not the CLI's lock


def _without_timing(obj):
    """``obj`` without its wall times (keys ``seconds`` and ``wall_s``, at any depth)."""
    if isinstance(obj, dict):
        return {k: _without_timing(v) for k, v in obj.items() if k not in ("seconds", "wall_s")}
    if isinstance(obj, list):
        return [_without_timing(v) for v in obj]
    return obj


def _record_without_timing(path):
    doc = json.loads(path.read_text())
    doc.pop("stats", None)
    if "goal_attainment" in doc:
        doc["goal_attainment"].pop("stats", None)
    return doc


def test_help_lists_the_entry_points_first() -> None:
    text = pydoc.render_doc(ehsa_opt, renderer=pydoc.plaintext)
    for name in ehsa_opt.ENTRY_POINTS:
        assert f"{name}(" in text
        assert callable(getattr(ehsa_opt, name))
    assert list(ehsa_opt.__all__[:len(ehsa_opt.ENTRY_POINTS)]) == list(ehsa_opt.ENTRY_POINTS)


def test_optimize_api_equals_cli_and_writes_nothing(tmp_path, monkeypatch) -> None:
    monkeypatch.chdir(tmp_path)
    problem = ehsa_opt.load_problem(PAPER)
    result = ehsa_opt.optimize(problem, termination=("n_gen", 4), pop_size=12, seed=3)
    assert list(tmp_path.iterdir()) == []  # nothing written
    assert result.success, result.message
    # the paper's problem with catalogue hardware: motor, screw, winding, J_t, R_e; every
    # hardware limit a constraint
    assert result.X.shape == (result.F.shape[0], problem.n_var) and result.F.shape[1] == 4
    assert problem.n_var == 5 and {"motor", "screw", "winding"} <= set(problem.space.names)
    assert result.G.shape == (result.F.shape[0], len(problem.constraint_names))
    assert np.all(result.G <= 1e-9)
    assert np.all((result.X >= 0) & (result.X <= 1))
    assert result.design == result.record["design"]
    table = result.table()
    for col in ("load_ohm", "power_W", "efficiency", "comfort", "inverse_power", "feasible"):
        assert len(table[col]) == result.F.shape[0]
    # the minimised forms are the inverses of the reported quantities
    np.testing.assert_allclose(np.asarray(table["inverse_efficiency"]),
                               1.0 / np.asarray(table["efficiency"]), rtol=1e-12)
    api_dir, cli_dir = tmp_path / "api", tmp_path / "cli"
    result.save(api_dir)
    assert main(["optimize", PAPER, "--method", "nsga2", "--pop", "12", "--gens", "4",
                 "--seed", "3", "--out", str(cli_dir)]) == 0
    assert (api_dir / "pareto.csv").read_text() == (cli_dir / "pareto.csv").read_text()
    assert (api_dir / "front.csv").read_text() == (cli_dir / "front.csv").read_text()
    assert _record_without_timing(api_dir / "result.json") == \
        _record_without_timing(cli_dir / "result.json")
    back = ehsa_opt.DesignResult.load(api_dir)
    np.testing.assert_allclose(back.X, result.X, rtol=1e-12, atol=1e-15)
    np.testing.assert_array_equal(back.F, result.F)
    np.testing.assert_array_equal(back.G, result.G)
    assert back.files["pareto.csv"] == result.files["pareto.csv"]
    fig = back.plot()  # the loaded front is drawn from front.csv
    assert len(fig.axes) >= 6


def test_public_nsga2_path_finds_a_feasible_front() -> None:
    """The seed population is the problem's: a pymoo NSGA-II with its default sampling,
    and the design room's run_nsga2 on build_problem, start from the feasible designs of a
    seeded screening of the catalogue space."""
    from pymoo.algorithms.moo.nsga2 import NSGA2

    from ehsa_opt.design import run_nsga2
    from ehsa_opt.design.config import load_design_config
    from ehsa_opt.design.optimize import build_problem
    problem = ehsa_opt.load_problem(PAPER)
    assert problem.initial is not None
    res = ehsa_opt.optimize(problem, algorithm=NSGA2(pop_size=20), termination=("n_gen", 15),
                            seed=0, goal_attainment=False, time_domain_check=False)
    assert res.success and np.all(res.G <= 1e-9), res.message
    built = build_problem(load_design_config(PAPER))
    pr = run_nsga2(built, pop_size=20, n_gen=15)
    assert pr.success, pr.message
    # the seeds are feasible designs of the catalogue space, one per motor/screw first
    G = built.evaluate_unit(built.initial)[:, built.n_obj:]
    assert len(built.initial) >= 1 and np.all(G <= 0)


@pytest.mark.parametrize("algorithm", ["SMSEMOA", "AGEMOEA", "NSGA3"])
def test_other_pymoo_algorithms(algorithm: str) -> None:
    from pymoo.util.ref_dirs import get_reference_directions
    if algorithm == "SMSEMOA":
        from pymoo.algorithms.moo.sms import SMSEMOA as A
        algo = A(pop_size=12)
    elif algorithm == "AGEMOEA":
        pytest.importorskip("numba", reason="pymoo's AGE-MOEA needs numba")
        from pymoo.algorithms.moo.age import AGEMOEA as A
        algo = A(pop_size=12)
    else:
        from pymoo.algorithms.moo.nsga3 import NSGA3 as A
        algo = A(pop_size=12, ref_dirs=get_reference_directions("energy", 4, 12, seed=1))
    problem = ehsa_opt.load_problem(PAPER)
    res = ehsa_opt.optimize(problem, algorithm=algo, termination=("n_gen", 4), seed=1,
                            goal_attainment=False, time_domain_check=False)
    assert res.success and res.record["algorithm"] == algorithm, res.message
    assert np.all(res.G <= 1e-9) and res.F.shape[1] == 4
    assert len(res.record["hypervolume"]["history"]) == 4
    # seeded: the same run again gives the same front
    again = ehsa_opt.optimize(ehsa_opt.load_problem(PAPER), algorithm=type(algo)(
        **({"ref_dirs": algo.ref_dirs} if algorithm == "NSGA3" else {}), pop_size=12),
        termination=("n_gen", 4), seed=1, goal_attainment=False, time_domain_check=False)
    np.testing.assert_array_equal(res.F, again.F)


def test_user_objective_and_constraint() -> None:
    problem = ehsa_opt.load_problem(PAPER)
    peak = 3.5  # Gaussian peak factor of the example: peak ≈ 3.5 × rms
    ext = (problem
           .with_objective("peak_current_A", lambda o: peak * o["current_rms_A"], "A")
           .with_constraint("stroke_rms_m", lambda o: o["stroke_rms_m"], upper=0.0195,
                            unit="m"))
    n_con = len(problem.constraint_names)
    assert problem.n_obj == 4 and ext.n_obj == 5 and ext.n_ieq_constr == n_con + 1
    res = ehsa_opt.optimize(ext, termination=("n_gen", 6), pop_size=16, seed=2,
                            time_domain_check=False)
    assert res.success, res.message
    t = res.table()
    np.testing.assert_allclose(np.asarray(t["peak_current_A"]),
                               peak * np.asarray(t["current_rms_A"]), rtol=1e-12)
    assert np.all(np.asarray(t["stroke_rms_m"]) <= 0.0195 * (1 + 1e-9))
    assert res.F.shape[1] == 5 and res.objective_names[-1] == "peak_current_A"
    assert res.record["units"] == {"peak_current_A": "A", "stroke_rms_m": "m"}
    assert "stroke_rms_m" in res.constraint_names and res.G.shape[1] == n_con + 1
    with pytest.raises(ehsa_opt.ParameterError, match="goal attainment needs"):
        ehsa_opt.optimize(ext, method="goal-attainment")
    with pytest.raises(ehsa_opt.ParameterError, match="exists already"):
        problem.with_objective("comfort", lambda o: o["comfort"])
    with pytest.raises(ehsa_opt.ParameterError, match="does not give"):
        problem.with_objective("x_A", lambda o: o["no_such_output"]).evaluate_unit(
            np.full((1, problem.n_var), 0.5))


def test_no_feasible_design_is_a_clear_failure(caplog) -> None:
    problem = ehsa_opt.load_problem(PAPER).with_constraint(
        "stroke_rms_m", lambda o: o["stroke_rms_m"], upper=1e-6, unit="m")
    with caplog.at_level(logging.WARNING, logger="ehsa_opt"):
        res = ehsa_opt.optimize(problem, termination=("n_gen", 3), pop_size=12, seed=0,
                                time_domain_check=False)
    assert not res.success
    assert "NO design within the constraints" in res.message
    assert res.summary().startswith("FAILED: ")
    assert any("NO design within the constraints" in r.getMessage() for r in caplog.records)


def test_sweep_api_equals_cli(tmp_path) -> None:
    res = ehsa_opt.sweep(SWEEP)
    assert len(res.rows) > 1 and res.table()["power_W"] is not None
    res.save(tmp_path / "api")
    assert main(["sweep", SWEEP, "--out", str(tmp_path / "cli")]) == 0
    assert (tmp_path / "api" / "sweep.csv").read_text() == \
        (tmp_path / "cli" / "sweep.csv").read_text()
    assert _files(tmp_path / "api") == _files(tmp_path / "cli")
    back = ehsa_opt.SweepResult.load(tmp_path / "api")
    assert back.design_keys == res.design_keys
    assert [r["power_W"] for r in back.rows] == [r["power_W"] for r in res.rows]


def test_sweep_grid_from_python(tmp_path) -> None:
    """A lead × load grid at two speeds on a file without a [sweep] table."""
    res = ehsa_opt.sweep(QUARTER_CAR, design={"lead_mm_per_rev": [5.0, 10.0],
                                             "load_ohm": [20.0, 50.0, 100.0]},
                         speed_km_per_h=[50.0, 100.0], friction=["none"])
    assert len(res.rows) == 12 and res.design_keys == ("lead_mm_per_rev", "load_ohm")
    assert {r["speed_km_per_h"] for r in res.rows} == {50.0, 100.0}
    fig = res.plot()
    assert len(fig.axes) >= 4
    with pytest.raises(ehsa_opt.ParameterError, match="no \\[sweep\\] table"):
        ehsa_opt.sweep(QUARTER_CAR)


def test_simulate_api_equals_cli(tmp_path, capsys) -> None:
    res = ehsa_opt.simulate(QUARTER_CAR)
    assert main(["simulate", QUARTER_CAR, "--json"]) == 0
    cli = json.loads(capsys.readouterr().out)
    api = dict(res.record)
    cli.pop("wall_s")
    api.pop("wall_s")
    assert api == cli
    fig = res.plot()
    assert len(fig.axes) == 4
    res.save(tmp_path)
    back = ehsa_opt.SimulationResult.load(tmp_path)
    assert back.metrics == res.metrics


def test_identify_api_equals_cli(tmp_path) -> None:
    from ehsa_opt.datasets.synthetic import SyntheticSpec, write_synthetic
    data = tmp_path / "d"
    write_synthetic(data, SyntheticSpec(effects={}, frequencies_hz=(1.0, 2.0, 3.0),
                                        loads_ohm=(47.0,)))
    res = ehsa_opt.identify(data, starts=2, seed=1)
    assert res.success and set(res.friction_sets) >= {"min", "best", "max"}
    table = res.table()
    assert list(table["file"]) == [t["file"] for t in res.record["tests"]]
    res.save(tmp_path / "api")
    assert main(["identify", str(data), "--out", str(tmp_path / "cli"), "--starts", "2",
                 "--seed", "1"]) == 0
    api = json.loads((tmp_path / "api" / "identification.json").read_text())
    cli = json.loads((tmp_path / "cli" / "identification.json").read_text())
    assert _without_timing(api) == _without_timing(cli)
    assert api["bounds"] == cli["bounds"] and api["friction_sets"] == cli["friction_sets"]
    back = ehsa_opt.IdentificationResult.load(tmp_path / "api")
    assert back.friction_sets == res.friction_sets and back.report is not None


class _Parabolas:
    """f1 = a² + b, f2 = (a − 2)² + b: Pareto set b = 0, front f2 = (√f1 − 2)²."""

    objective_names = ("f1", "f2")

    def __call__(self, d):
        a, b = np.asarray(d["a"], float), np.asarray(d["b"], float)
        return {"f1": a ** 2 + b, "f2": (a - 2.0) ** 2 + b}


def test_a_problem_built_in_python(tmp_path) -> None:
    """A DesignProblem of one's own space and evaluator (no problem file) is solved by the
    same entry point; its front is the analytic one."""
    space = ehsa_opt.DesignSpace.from_bounds({"a": [0.0, 2.0], "b": [0.0, 1.0]}, log=[])
    problem = ehsa_opt.DesignProblem(space, _Parabolas())
    res = ehsa_opt.optimize(problem, termination=("n_gen", 30), pop_size=20, seed=4)
    assert res.success and res.G is None
    t = res.table()
    f1, f2 = np.asarray(t["f1"]), np.asarray(t["f2"])
    gap = f2 - (np.sqrt(f1) - 2.0) ** 2  # distance above the true front, > 0
    assert np.all(gap > -1e-12) and np.median(gap) < 1e-3
    assert np.mean(np.asarray(t["b"]) < 0.01) >= 0.8
    assert np.ptp(np.asarray(t["a"])) > 1.5  # the front spans the Pareto set
    res.save(tmp_path)
    back = ehsa_opt.DesignResult.load(tmp_path)
    np.testing.assert_array_equal(back.F, res.F)
    with pytest.raises(ehsa_opt.ParameterError, match="needs a problem file"):
        ehsa_opt.optimize(problem, method="goal-attainment")


def test_discrepancy_api_equals_cli_and_writes_nothing(tmp_path, monkeypatch) -> None:
    """``ehsa_opt.discrepancy`` returns the engine's result in memory (nothing written in
    the working folder); ``save`` writes what the command writes, with the same answer."""
    import json

    from ehsa_opt.cli import main
    from ehsa_opt.datasets.synthetic import SyntheticSpec, write_synthetic
    data = tmp_path / "data"
    write_synthetic(data, SyntheticSpec(effects={"voltage_drop": {"voltage_drop_V": 0.5}},
                                        frequencies_hz=(1.5, 3.0), loads_ohm=(15.0, 109.0),
                                        cycles=1.0, seed=5))
    work = tmp_path / "work"
    work.mkdir()
    monkeypatch.chdir(work)
    res = ehsa_opt.discrepancy(data, top=1)
    assert list(work.iterdir()) == []
    assert res.effect == "voltage_drop" and "voltage_drop" in res.summary()
    assert main(["discrepancy", str(data), "--out", str(tmp_path / "cli"), "--top", "1",
                 "--wall-cap-s", "0"]) == 0
    cli = json.loads((tmp_path / "cli" / "discrepancy.json").read_text())
    res.save(tmp_path / "api")
    api = json.loads((tmp_path / "api" / "discrepancy.json").read_text())
    for key in ("effect", "effects", "error_before", "error_after", "steps", "criterion",
                "member_fits"):
        assert api[key] == cli[key], key
    assert [c["parameters"] for c in api["candidates"]] == \
        [c["parameters"] for c in cli["candidates"]]
    with pytest.raises(ValueError, match="bench data directory"):
        ehsa_opt.discrepancy(tmp_path / "nowhere")
