"""The committed reference report is what the code computes (results/reference/REPORT.md)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from ehsa_opt.pipeline.reference_check import report_cells, report_differences

REFERENCE = Path(__file__).resolve().parents[2] / "results" / "reference"

REPORT_A = """# report

## 1. Discrepancy on EMPS

### Identified `drive_lag + asymmetric_friction` parameters

| model | error (%) | time (s) |
|---|---|---|
| baseline | 7.59 | 12.0 |
| drive_lag + asymmetric_friction | 4.59 | 30.1 |

## 2. Run log

| step | this run | compute time (s) |
|---|---|---|
| Discrepancy | computed | 300.2 |
"""


def test_differences_name_a_changed_model_and_number_but_not_timings_or_rounding():
    assert report_differences(REPORT_A, REPORT_A) == []
    # timings (a time column, the run log) are the machine's, not the code's
    other_machine = REPORT_A.replace("30.1", "55.0").replace("300.2", "512.9")
    assert report_differences(REPORT_A, other_machine) == []
    # one unit of the last printed digit is rounding
    assert report_differences(REPORT_A, REPORT_A.replace("4.59", "4.60")) == []
    stale = REPORT_A.replace("drive_lag + asymmetric_friction", "asymmetric_friction") \
        .replace("4.59", "12.17").replace("7.59", "12.44")
    diff = report_differences(stale, REPORT_A)
    assert any("heading 0" in d and "asymmetric_friction" in d for d in diff)
    assert any("baseline" in d and "'12.44' -> current '7.59'" in d for d in diff)
    assert any("only in the current report ('4.59')" in d for d in diff)
    assert "Discrepancy on EMPS / table 0 / baseline / error (%)" in report_cells(REPORT_A)


def test_the_committed_reference_is_a_full_run_of_this_version_with_its_figures():
    from ehsa_opt.utils.version import __version__
    text = (REFERENCE / "REPORT.md").read_text(encoding="utf-8")
    assert f"(full mode, ehsa_opt {__version__})" in text.split("\n\n")[1]
    for rel in re.findall(r"!\[[^\]]*\]\(([^)]+)\)", text):
        assert (REFERENCE / rel).is_file(), f"REPORT.md links {rel}, which is not committed"


@pytest.mark.slow
def test_the_committed_reference_is_what_the_code_computes(tmp_path):
    """Regenerate the full report and compare every heading and table cell with the
    committed one (numbers to 0.1 % or the last printed digit). When this fails, the
    reference is stale: regenerate it with
    ``python -m ehsa_opt reproduce --out results/reference --overwrite`` and commit it."""
    from ehsa_opt.pipeline.reproduce import reproduce
    report = reproduce(tmp_path / "ref", quick=False, jobs=2, log=lambda s: None)
    diff = report_differences((REFERENCE / "REPORT.md").read_text(encoding="utf-8"),
                              report.read_text(encoding="utf-8"))
    assert not diff, ("results/reference/REPORT.md is stale; regenerate it (python -m "
                      "ehsa_opt reproduce --out results/reference --overwrite):\n"
                      + "\n".join(diff[:40]))


def test_committed_results_record_no_path_of_the_machine_they_ran_on():
    """Package files are recorded by their package path, an identification's data folder
    relative to the file: nothing under a home, work or temporary folder."""
    bad = re.compile(r"(?<![\w.])/(?:work|tmp|home|root|Users|private|var)/")
    hits = [f"{p.relative_to(REFERENCE)}: {m.group(0)}"
            for p in sorted(REFERENCE.rglob("*")) if p.suffix in (".json", ".md", ".csv")
            for m in [bad.search(p.read_text(errors="replace"))] if m]
    assert hits == []
