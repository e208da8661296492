"""The reproduce pipeline caches steps by input hash and resumes after an interruption."""

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
