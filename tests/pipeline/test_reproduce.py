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
                                                              "sum": sum(range(10 ** 6))})


def _side_fails(ctx):
    raise ValueError("broken side data")


def test_background_step_runs_beside_keeps_its_place_and_is_cached(tmp_path):
    import os
    seen = {}

    def main_step(ctx):
        seen["main_pid"] = os.getpid()
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
    logs.clear()
    reproduce(tmp_path, steps=steps, jobs=2, log=logs.append)  # second run: from the cache
    assert any("Side step: cached" in m for m in logs)
    assert not any("started beside" in m for m in logs)


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
