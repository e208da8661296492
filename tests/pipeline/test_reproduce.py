"""The reproduce pipeline caches steps by input hash and resumes after an interruption."""

import json

import pytest

from ehsa_opt.pipeline.reproduce import Step, StepOutput, reproduce


def _steps(calls, fail_second=False):
    def one(ctx):
        calls.append("one")
        return StepOutput("first section", [], {"value": 41})

    def two(ctx):
        calls.append("two")
        if fail_second and calls.count("two") == 1:
            raise KeyboardInterrupt  # a user killing the run midway
        return StepOutput(f"value + 1 = {ctx.results['one']['value'] + 1}", [], {})

    return [Step("one", "Step one", one), Step("two", "Step two", two, depends=("one",))]


def test_interrupted_run_resumes_without_recomputing(tmp_path):
    calls, logs = [], []
    with pytest.raises(KeyboardInterrupt):
        reproduce(tmp_path, steps=_steps(calls, fail_second=True), log=logs.append)
    assert calls == ["one", "two"]
    report = reproduce(tmp_path, steps=_steps(calls, fail_second=True), log=logs.append)
    assert calls == ["one", "two", "two"]  # step one came from the cache
    assert any("Step one: cached" in m for m in logs)
    text = report.read_text()
    assert "value + 1 = 42" in text
    # a third run recomputes nothing and writes the same report body
    reproduce(tmp_path, steps=_steps(calls), log=logs.append)
    assert calls == ["one", "two", "two"]
    assert report.read_text().split("## Run log")[0] == text.split("## Run log")[0]


def test_changed_inputs_invalidate_the_cache(tmp_path):
    calls = []
    steps = _steps(calls)
    reproduce(tmp_path, steps=steps, log=lambda m: None)
    changed = [Step("one", "Step one", steps[0].run, inputs=lambda ctx: "new data"), steps[1]]
    reproduce(tmp_path, steps=changed, log=lambda m: None)
    # step one's inputs changed, and step two depends on it: both recomputed
    assert calls == ["one", "two", "one", "two"]


def test_friction_bounds_choice_reruns_only_what_uses_the_friction_sets(tmp_path):
    """--friction-bounds paper reaches the steps downstream of the identification
    (they see ctx.friction_bounds) and re-runs them; the identification itself is reused."""
    seen = []

    def ident(ctx):
        seen.append(("identification", ctx.friction_bounds))
        return StepOutput("identified", [], {"value": 1})

    def study(ctx):
        seen.append(("study", ctx.friction_bounds))
        return StepOutput(f"bounds = {ctx.friction_bounds}", [], {})

    steps = [Step("identification", "Identification", ident),
             Step("study", "A study", study, depends=("identification",))]
    reproduce(tmp_path, steps=steps, log=lambda m: None)
    report = reproduce(tmp_path, steps=steps, log=lambda m: None, friction_bounds="paper")
    assert seen == [("identification", "data"), ("study", "data"), ("study", "paper")]
    text = report.read_text()
    assert "bounds = paper" in text and "paper's per-parameter method" in text
    with pytest.raises(ValueError, match="friction_bounds must be one of data, paper"):
        reproduce(tmp_path / "x", steps=steps, friction_bounds="widest")


def _slow_side(ctx):
    """A background step: its own pid (it must not be the parent's) and some work."""
    import os
    return StepOutput(f"side markdown pid {os.getpid()}", [], {"pid": os.getpid(),
                                                              "sum": sum(range(10 ** 6)),
                                                              "jobs": ctx.jobs})


def _side_fails(ctx):
    raise ValueError("broken side data")


def test_background_step_runs_beside_keeps_its_place_and_is_cached(tmp_path):
    import os
    seen = {}

    def main_step(ctx):
        seen["main_pid"] = os.getpid()
        seen["main_jobs"] = ctx.jobs
        return StepOutput("main markdown", [], {"x": 1})

    steps = [Step("side", "Side step", _slow_side, background=True),
             Step("main", "Main step", main_step)]
    logs: list[str] = []
    report = reproduce(tmp_path, steps=steps, jobs=2, log=logs.append).read_text()
    assert any("started beside" in m for m in logs)
    assert report.index("## 1. Side step") < report.index("## 2. Main step")  # its place
    cached = json.loads((tmp_path / "cache" / "side.json").read_text())["payload"]
    side_pid = int(cached["markdown"].split()[-1])
    assert side_pid != seen["main_pid"] and side_pid != os.getpid()  # really forked
    assert cached["results"]["sum"] == sum(range(10 ** 6))
    # two jobs, one step beside: one job each, no third busy process
    assert cached["results"]["jobs"] == 1 and seen["main_jobs"] == 1
    assert any("started beside the other steps (1 job)" in m for m in logs)
    logs.clear()
    reproduce(tmp_path, steps=steps, jobs=2, log=logs.append)  # second run: from the cache
    assert any("Side step: cached" in m for m in logs)
    assert not any("started beside" in m for m in logs)


def test_jobs_are_shared_among_the_processes_of_a_run():
    from ehsa_opt.pipeline.background import shared_jobs
    assert shared_jobs(2, 2) == (1, 1)  # reproduce --jobs 2: two discrepancy steps beside
    assert shared_jobs(2, 1) == (1, 1)
    assert shared_jobs(4, 2) == (1, 2)
    assert shared_jobs(6, 2) == (2, 2)
    assert shared_jobs(8, 1) == (4, 4)
    assert shared_jobs(3, 0) == (3, 3)  # nothing beside: the main process has them all


def test_background_step_inline_with_one_job_and_errors_reach_the_parent(tmp_path):
    import os
    steps = [Step("side", "Side step", _slow_side, background=True)]
    reproduce(tmp_path / "a", steps=steps, jobs=1, log=lambda m: None)
    cached = json.loads((tmp_path / "a" / "cache" / "side.json").read_text())["payload"]
    assert cached["results"]["pid"] == os.getpid()  # one job: run in this process
    bad = [Step("side", "Side step", _side_fails, background=True),
           Step("main", "Main step", lambda ctx: StepOutput("m"))]
    with pytest.raises(RuntimeError, match="step 'side' failed: ValueError: broken side data"):
        reproduce(tmp_path / "b", steps=bad, jobs=2, log=lambda m: None)
    # the step that ran is kept for the resumed run
    assert (tmp_path / "b" / "cache" / "main.json").exists()


def test_tied_rows_of_the_identifiability_table_are_ordered_by_name():
    """Directions counted in as many tests are listed by name: the table does not depend on
    the order the counts were collected in (a set's order changes with the hash seed)."""
    from types import SimpleNamespace

    from ehsa_opt.pipeline.identify_report import _identifiability_lines
    counts = [("b / c", 1), ("a", 7), ("c", 1), ("a / b", 1), ("d", 7)]
    tables = []
    for order in (counts, counts[::-1], counts[2:] + counts[:2]):
        rep = SimpleNamespace(identifiable={"non_identifiable_directions": dict(order)},
                              joint=None)
        lines = _identifiability_lines(SimpleNamespace(custom_data=False), rep, [],
                                       SimpleNamespace(identifiable_rtol=1e-6))
        tables.append([ln for ln in lines if ln.startswith("| ") and ln.endswith(" |")
                       and ln[2:3] != "q" and "direction" not in ln])
    assert tables[0] == tables[1] == tables[2]
    assert tables[0] == ["| a | 7 |", "| d | 7 |", "| a / b | 1 |", "| b / c | 1 |", "| c | 1 |"]


_WEAK_COUNTS = """
from types import SimpleNamespace as N
from ehsa_opt.estimation.identify_result import summarise_identifiability
dirs = [{"identifiable": False, "main": m} for m in
        (["nut_coulomb_N"], ["bearing_coulomb_Nm", "nut_viscous_Ns_per_m"], ["nut_breakaway_N"],
         ["bearing_breakaway_Nm"], ["x1"], ["x2"], ["x3"], ["x4"])]
fit = N(success=True, free=["a"], parameters={"a": 1.0}, identifiability={
    "directions": dirs, "condition_number": 1.0, "non_identifiable": [], "combinations": []})
data = N(tests=[N(file="a.csv"), N(file="b.csv")], harvester=N(lead_m_per_rad=1e-3),
         has_generator=False)
print(list(summarise_identifiability(data, [fit, fit])["non_identifiable_directions"]))
"""


def test_weak_direction_counts_do_not_depend_on_the_hash_seed():
    import os
    import subprocess
    import sys
    from tests.paths import ROOT
    outs = {subprocess.run([sys.executable, "-c", _WEAK_COUNTS], capture_output=True, text=True,
                           cwd=ROOT, env={**os.environ, "PYTHONHASHSEED": str(seed)},
                           check=True).stdout for seed in (1, 2, 3)}
    assert len(outs) == 1, outs
