"""The vehicle steps of the report: intervals, shares beyond the limits, captions
(quick mode, embedded friction: no identification step needed)."""

from __future__ import annotations

import re

import pytest

from ehsa_opt.pipeline.base import Context


@pytest.fixture()
def ctx(tmp_path):
    return Context(tmp_path, True, 1)


def test_fig21_gives_intervals_judges_the_paper_on_them_and_flags_the_hardware(ctx):
    from ehsa_opt.pipeline.quarter_car_report import step_fig21
    out = step_fig21(ctx)
    md = out.markdown
    # every power with its interval; the paper judged on it; a caption under the figure
    assert re.search(r"\| none \| \d+(\.\d+)? ± \d+(\.\d+)? / 174\.9 \((consistent with|below|"
                     r"above) the paper's 174\.9\)", md)
    assert "95 % intervals over 4 Gaussian realisations" in md
    assert re.search(r"!\[Fig 21\]\(figures/fig21_power_history\.png\)\n\n\*Fig 21\. ", md)
    # the paper's optimum turns its 7 mm screw beyond 6250 rpm: not realisable, said so
    assert "NOT REALISABLE: screw speed beyond 6250 rpm" in md
    iv = out.results["intervals"]["power_W"]
    assert len(iv) == 3 and all(r["n"] == 4 and r["half_width"] > 0 for r in iv)
    assert (ctx.out_dir / "figures" / "fig21_power_history.png").is_file()


def test_fig14_carries_a_caption_from_its_numbers(ctx):
    from ehsa_opt.pipeline.quarter_car_report import step_fig14
    out = step_fig14(ctx)
    lo, hi = out.results["open circuit"]
    assert "*Fig 14. Force against velocity" in out.markdown and "shaded" in out.markdown
    assert f"open circuit (c_eq {lo:.0f}–{hi:.0f} N s/m" in out.markdown


def test_the_road_study_carries_paired_changes_limits_and_a_caption(ctx):
    from ehsa_opt.pipeline.quarter_car_report import step_fig15_16
    out = step_fig15_16(ctx)
    car, seater = out.markdown.split("### Fig 16")
    # paired power changes with intervals, the shares beyond the limits, a caption
    assert re.search(r"\| min \| [\d.]+ \| \d+ \| [\d.]+ ± [\d.]+ \| -[\d.]+ ± [\d.]+ % \|", car)
    assert "time beyond limits: tyre lift / stroke / screw speed / voltage" in car
    assert "*Fig 15. passenger_car on the class C design road" in car
    assert "(Welch, 8 Hann segments overlapping by half" in car
    # the single seater lifts its tyre: INVALID, no conclusion drawn
    assert "INVALID: tyre leaves the ground" in seater and "No conclusion is drawn" in seater
    change = out.results["passenger_car"]["power_change_interval"]["max"]
    assert change["mean"] < 0 and change["half_width"] > 0
