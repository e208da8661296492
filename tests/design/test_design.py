"""Design machinery on analytic test functions with known answers."""

from __future__ import annotations

import math

import numpy as np
import pytest

from ehsa_opt.design import (PAPER_BOX, DesignProblem, DesignSpace, dominates_by, hypervolume,
                             non_dominated, pick_preferred, run_nsga2, solve_goal_attainment)
from ehsa_opt.physics.params import ParameterError


class Parabolas:
    """f1 = a² + b, f2 = (a − 2)² + b on a ∈ [0, 2], b ∈ [0, 1].

    Pareto set: b = 0, a ∈ [0, 2]; front f2 = (√f1 − 2)².
    """

    objective_names = ("f1", "f2")

    def __call__(self, d):
        a, b = np.asarray(d["a"], float), np.asarray(d["b"], float)
        return {"f1": a ** 2 + b, "f2": (a - 2.0) ** 2 + b}

    def fingerprint(self):
        return {"kind": "parabolas"}


def _problem():
    space = DesignSpace.from_bounds({"a": [0.0, 2.0], "b": [0.0, 1.0]}, log=[])
    return DesignProblem(space, Parabolas())


def test_design_space_roundtrip_and_log_scaling():
    d = PAPER_BOX.from_unit(np.array([[0.0, 0.0, 0.0, 0.0], [1.0, 1.0, 1.0, 1.0],
                                      [0.5, 0.5, 0.5, 0.5]]))
    assert d["total_inertia_gcm2"][0] == pytest.approx(250.0)
    assert d["speed_constant_rpm_per_V"][1] == pytest.approx(11900.0)
    # log-scaled variables: the middle of the cube is the geometric mean
    assert d["load_ohm"][2] == pytest.approx(math.sqrt(1.0 * 10000.0))
    assert d["lead_mm_per_rev"][2] == pytest.approx(12.5)  # linear
    U = PAPER_BOX.to_unit({k: v[2] for k, v in d.items()})
    assert np.allclose(U, 0.5)


@pytest.mark.parametrize("bounds,match", [
    ({"load_ohm": [100.0, 10.0]}, "lower bound 100 > upper bound 10"),
    ({"load_ohm": [10.0, 10.0]}, "lower bound = upper bound"),
    ({"load_ohm": [0.0, 10.0]}, None),
    ({"load_ohm": "10"}, r"\[lower, upper\]"),
])
def test_design_space_rejects_bad_bounds(bounds, match):
    if match is None:  # lower 0 is fine for a linear variable, not for a log one
        DesignSpace.from_bounds(bounds, log=[])
        with pytest.raises(ParameterError, match="log-scaled"):
            DesignSpace.from_bounds(bounds, log=["load_ohm"])
    else:
        with pytest.raises(ParameterError, match=match):
            DesignSpace.from_bounds(bounds)


def test_problem_is_pymoo_and_vectorised():
    from pymoo.core.problem import Problem
    p = _problem()
    assert isinstance(p, Problem)
    out = p.evaluate(np.array([[0.5, 0.0], [0.0, 1.0]]), return_as_dictionary=True)
    assert np.allclose(out["F"], [[1.0, 1.0], [1.0, 5.0]])


def test_goal_attainment_symmetric_weights():
    # min γ s.t. a² + b − γ ≤ 0.5, (a−2)² + b − γ ≤ 0.5  →  a = 1, b = 0, γ = 0.5
    res = solve_goal_attainment(_problem(), [0.5, 0.5], [1.0, 1.0], n_starts=3, seed=0)
    assert res.success, res.message
    assert res.design["a"] == pytest.approx(1.0, abs=1e-5)
    assert res.design["b"] == pytest.approx(0.0, abs=1e-6)
    assert res.gamma == pytest.approx(0.5, abs=1e-6)
    assert len(res.history) >= 2 and res.history[0]["gamma"] > res.gamma - 1e-9


def test_goal_attainment_unequal_weights_known_answer():
    # weights (1, 3): both constraints active, 2a² + 4a − 5 = 0
    a = (-4.0 + math.sqrt(16.0 + 40.0)) / 4.0
    res = solve_goal_attainment(_problem(), [0.5, 0.5], [1.0, 3.0], n_starts=2, seed=1)
    assert res.success, res.message
    assert res.design["a"] == pytest.approx(a, abs=1e-5)
    assert res.gamma == pytest.approx(a * a - 0.5, abs=1e-6)


def test_goal_attainment_hard_constraint_weight_zero():
    # weight 0 on f2: hard constraint f2 ≤ 2 → a ≥ 2 − √2; minimise f1 → a = 2 − √2
    res = solve_goal_attainment(_problem(), [0.0, 2.0], [1.0, 0.0], n_starts=2, seed=0)
    assert res.success, res.message
    assert res.design["a"] == pytest.approx(2 - math.sqrt(2), abs=1e-5)
    assert res.objectives["f2"] <= 2.0 + 1e-7


@pytest.mark.parametrize("goals,weights,match", [
    ([0.0, 1.0], [0.0, 1.0], "goal 0 and weight 0"),
    ([0.0, 1.0], None, "goal 0 and weight 0"),  # default weights |goal|
    ([1.0, 1.0], [1.0, -1.0], "must be >= 0"),
    ([1.0], [1.0], "need 2 goals"),
])
def test_goal_attainment_bad_goals(goals, weights, match):
    with pytest.raises(ParameterError, match=match):
        solve_goal_attainment(_problem(), goals, weights)


def test_non_dominated_hypervolume_and_picks():
    F = np.array([[0.0, 1.0], [0.2, 0.2], [1.0, 0.0], [0.5, 0.5], [0.2, 0.2]])
    mask = non_dominated(F)
    assert mask.tolist() == [True, True, True, False, False]
    # HV of the three points against (1, 1): 0.8 * 0.8 = 0.64
    assert hypervolume(F[mask], np.array([1.0, 1.0])) == pytest.approx(0.64)
    # against (2, 2): 0.2·1 + 0.8·1.8 + 1·2 = 3.64
    assert hypervolume(F[mask], np.array([2.0, 2.0])) == pytest.approx(3.64)
    assert pick_preferred(F[mask], "knee") == 1
    assert pick_preferred(F[mask], "compromise") == 1
    assert pick_preferred(F[mask], "preference", [1.0, 0.0]) == 0
    with pytest.raises(ValueError, match="unknown method"):
        pick_preferred(F, "best")
    assert dominates_by(F, np.array([0.6, 0.6]), 0.01).tolist() == [False, True, False, True,
                                                                    True]


def test_nsga2_finds_known_front_and_is_seeded():
    p = _problem()
    r1 = run_nsga2(p, pop_size=20, n_gen=40, seed=3)
    r2 = run_nsga2(p, pop_size=20, n_gen=40, seed=3)
    assert r1.to_csv_text() == r2.to_csv_text()
    f1, f2 = r1.F[:, 0], r1.F[:, 1]
    # near the analytic front f2 = (√f1 − 2)²
    gap = np.abs(f2 - (np.sqrt(f1) - 2.0) ** 2)
    assert np.median(gap) < 0.01 and np.max(gap) < 0.1
    assert np.ptp(r1.designs["a"]) > 1.8  # spread along the whole Pareto set
    assert r1.history[-1]["n_eval"] == 20 * 40
    hv = [h["hv"] for h in r1.history]
    assert hv[-1] > hv[0]  # (not monotone: crowding truncation may drop points)
    r3 = run_nsga2(p, pop_size=20, n_gen=40, seed=4)
    assert r3.to_csv_text() != r1.to_csv_text()


def test_nsga2_resume_gives_identical_front(tmp_path):
    p = _problem()
    straight = run_nsga2(p, pop_size=16, n_gen=6, seed=5)
    part = run_nsga2(p, pop_size=16, n_gen=6, seed=5, checkpoint=tmp_path / "ck", stop_after=3)
    assert not part.success and part.stats["generations"] == 3
    resumed = run_nsga2(_problem(), pop_size=16, n_gen=6, seed=5, resume=tmp_path / "ck")
    assert resumed.stats["resumed_from"] == 3
    assert resumed.to_csv_text() == straight.to_csv_text()
    assert [h["hv"] for h in resumed.history] == [h["hv"] for h in straight.history]
    # the checkpoint dir holds only the finished state file (atomic writes leave no temp)
    assert sorted(f.name for f in (tmp_path / "ck").iterdir()) == ["nsga2_checkpoint.npz"]
    with pytest.raises(ParameterError, match="pass the same --pop"):
        run_nsga2(_problem(), pop_size=20, n_gen=6, seed=5, resume=tmp_path / "ck")
    with pytest.raises(ParameterError, match="no checkpoint"):
        run_nsga2(_problem(), pop_size=16, n_gen=6, seed=5, resume=tmp_path / "nothing")
    other = DesignProblem(DesignSpace.from_bounds({"a": [0.0, 3.0], "b": [0.0, 1.0]}, log=[]),
                          Parabolas())
    with pytest.raises(ParameterError, match="different problem"):
        run_nsga2(other, pop_size=16, n_gen=6, seed=5, resume=tmp_path / "ck")


# ----------------------------------------------------------------------------- checkpoints
def _checkpointed(tmp_path, stop_after=3):
    ck = tmp_path / "ck"
    run_nsga2(_problem(), pop_size=16, n_gen=8, seed=7, checkpoint=ck, stop_after=stop_after)
    return ck, ck / "nsga2_checkpoint.npz"


@pytest.mark.parametrize("stop", [1, 2, 5, 7])
def test_resume_from_data_checkpoint_is_byte_identical_at_any_generation(tmp_path, stop):
    straight = run_nsga2(_problem(), pop_size=16, n_gen=8, seed=7)
    ck, _ = _checkpointed(tmp_path, stop)
    # interrupted twice: resume, stop again, resume to the end
    mid = min(stop + 1, 7)
    if mid > stop:
        run_nsga2(_problem(), pop_size=16, n_gen=8, seed=7, resume=ck, stop_after=mid)
    resumed = run_nsga2(_problem(), pop_size=16, n_gen=8, seed=7, resume=ck)
    assert resumed.to_csv_text() == straight.to_csv_text()
    assert resumed.history == straight.history
    assert resumed.stats["n_eval"] == straight.stats["n_eval"]


def test_checkpoint_is_data_without_pickle(tmp_path):
    _, f = _checkpointed(tmp_path)
    with np.load(f, allow_pickle=False) as z:  # loads without pickle: no object arrays
        assert {"header", "pop_X", "pop_F", "archive_F"} <= set(z.files)
        assert all(z[k].dtype != object for k in z.files)


def _rewrite_npz(src, dst, change):
    with np.load(src, allow_pickle=False) as z:
        arrays = {k: z[k].copy() for k in z.files}
    change(arrays)
    with open(dst, "wb") as fh:
        np.savez(fh, **arrays)


def test_altered_checkpoint_is_refused(tmp_path):
    ck, f = _checkpointed(tmp_path)

    def one_number(arrays):
        arrays["pop_F"][3, 1] *= 1.0 + 1e-9

    _rewrite_npz(f, f, one_number)
    with pytest.raises(ParameterError, match="SHA-256.*altered") as err:
        run_nsga2(_problem(), pop_size=16, n_gen=8, seed=7, resume=ck)
    assert str(f) in str(err.value) and "--checkpoint" in str(err.value)


def test_altered_header_is_refused(tmp_path):
    import json
    ck, f = _checkpointed(tmp_path)

    def history(arrays):
        head = json.loads(bytes(arrays["header"]).decode())
        head["history"][0]["hv"] += 0.5
        arrays["header"] = np.frombuffer(json.dumps(head).encode(), dtype=np.uint8)

    _rewrite_npz(f, f, history)
    with pytest.raises(ParameterError, match="altered"):
        run_nsga2(_problem(), pop_size=16, n_gen=8, seed=7, resume=ck)


@pytest.mark.parametrize("keep", [0.0, 0.3, 0.9])
def test_truncated_checkpoint_is_refused(tmp_path, keep):
    ck, f = _checkpointed(tmp_path)
    blob = f.read_bytes()
    f.write_bytes(blob[:int(keep * len(blob))])
    with pytest.raises(ParameterError, match="truncated|not an NSGA-II") as err:
        run_nsga2(_problem(), pop_size=16, n_gen=8, seed=7, resume=ck)
    assert str(f) in str(err.value)


def test_foreign_and_legacy_checkpoints_are_refused(tmp_path):
    import pickle
    ck = tmp_path / "ck"
    ck.mkdir()
    f = ck / "nsga2_checkpoint.npz"
    with open(f, "wb") as fh:  # a valid npz from elsewhere
        np.savez(fh, pop_X=np.zeros((4, 2)))
    with pytest.raises(ParameterError, match="not an NSGA-II checkpoint"):
        run_nsga2(_problem(), pop_size=16, n_gen=8, seed=7, resume=ck)
    f.write_text("pop_X,pop_F\n1,2\n")  # not a zip at all
    with pytest.raises(ParameterError, match="truncated|not an NSGA-II"):
        run_nsga2(_problem(), pop_size=16, n_gen=8, seed=7, resume=ck)
    f.unlink()

    class Boom:
        def __reduce__(self):
            return (pytest.fail, ("the old pickle checkpoint was loaded",))

    (ck / "algorithm.pkl").write_bytes(pickle.dumps({"algorithm": Boom()}))
    with pytest.raises(ParameterError, match="old pickle format"):
        run_nsga2(_problem(), pop_size=16, n_gen=8, seed=7, resume=ck)


def test_no_pickle_loads_in_the_package():
    import re
    from tests.paths import PACKAGE as pkg
    hits = [str(p) for p in pkg.rglob("*.py")
            if re.search(r"pickle\.loads?\(|allow_pickle\s*=\s*True", p.read_text())]
    assert hits == []


def test_incremental_archive_equals_filtering_everything():
    from ehsa_opt.design.pareto import update_archive
    rng = np.random.default_rng(0)
    for trial in range(60):
        m = int(rng.integers(2, 5))
        A = np.zeros((0, m))
        for _ in range(10):
            C = rng.integers(0, 6, (int(rng.integers(0, 12)), m)).astype(float)  # ties, dups
            U = np.vstack([A, C])
            A_new, changed = update_archive(A, C)
            assert np.array_equal(A_new, U[non_dominated(U)])
            assert changed == (not np.array_equal(A_new, A))
            A = A_new
