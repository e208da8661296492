"""Outputs never overwrite what ehsa-opt did not write (ehsa_opt/utils/output_folder.py).

Every command that writes a folder refuses a non-empty folder without the manifest of the
files ehsa-opt wrote there (exit 2, the folder and the fix named), before any work starts;
``--overwrite`` writes into it but never replaces a file the manifest does not list.  The
user's files are byte-identical afterwards.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from ehsa_opt.cli import main
from ehsa_opt.utils.io import atomic_write_text
from ehsa_opt.utils.output_folder import MANIFEST_NAME, ForeignFolderError, claimed
from tests.paths import ROOT


def run(capsys, *argv) -> tuple[int, str]:
    try:
        rc = main([str(a) for a in argv])
    except SystemExit as exc:  # argparse
        rc = exc.code
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return rc, err


def snapshot(folder: Path) -> dict[str, bytes]:
    """Every file under ``folder`` (hidden ones too) and its bytes."""
    return {f.relative_to(folder).as_posix(): f.read_bytes()
            for f in sorted(folder.rglob("*")) if f.is_file()}


@pytest.fixture
def no_work(monkeypatch):
    """The commands' library entry points fail the test if they are reached: a refusal
    must come before any work."""
    import importlib

    import ehsa_opt.design.test_plan as test_plan
    import ehsa_opt.pipeline.reproduce as reproduce

    def reached(*a, **k):
        raise AssertionError("the work started before the output folder was checked")
    monkeypatch.setattr(test_plan, "plan_from_files", reached)
    # the module (``ehsa_opt.api.discrepancy`` as an attribute is the function)
    discrepancy = importlib.import_module("ehsa_opt.api.discrepancy")
    monkeypatch.setattr(discrepancy, "run_discrepancy", reached)
    monkeypatch.setattr(reproduce, "reproduce", reached)


def _refused(rc: int, err: str, folder: Path, fix: str) -> None:
    assert rc == 2, err
    assert str(folder) in err and fix in err, err
    assert "nothing was changed" in err, err


def test_plan_tests_into_the_users_bench_data(tmp_path, capsys, no_work):
    data = tmp_path / "bench"
    shutil.copytree(ROOT / "data/bench_prototype", data)
    before = snapshot(data)
    ident = ROOT / "results/reference/identify_prototype.json"
    argv = ("plan-tests", ident, "--vehicle", "quarter_car_class_c", "--rig",
            data / "bench.toml", "--out", data)
    rc, err = run(capsys, *argv)
    _refused(rc, err, data, "--overwrite")
    assert MANIFEST_NAME in err
    rc, err = run(capsys, *argv, "--overwrite")  # still never replaces bench.toml
    _refused(rc, err, data, "bench.toml was not written by ehsa-opt")
    assert snapshot(data) == before


def _user_results(folder: Path) -> None:
    (folder / "tables").mkdir(parents=True)
    (folder / "figures").mkdir()
    (folder / "REPORT.md").write_text("# my thesis chapter\n")
    (folder / "tables/data_1.csv").write_text("a,b\n1,2\n")
    (folder / "figures/fig13_frequency_response.png").write_bytes(b"\x89PNG my figure")
    (folder / ".thesis.md.abcdefgh.tmp").write_text("autosave of my editor")


def test_reproduce_into_a_users_folder(tmp_path, capsys, no_work):
    out = tmp_path / "thesis"
    _user_results(out)
    before = snapshot(out)
    rc, err = run(capsys, "reproduce", "--quick", "--out", out)
    _refused(rc, err, out, "--overwrite")
    rc, err = run(capsys, "reproduce", "--quick", "--out", out, "--overwrite")
    _refused(rc, err, out, "REPORT.md was not written by ehsa-opt")
    assert snapshot(out) == before


def test_reproduce_library_refuses_a_users_folder_and_resumes_in_its_own(tmp_path):
    from ehsa_opt.pipeline.reproduce import Step, StepOutput, reproduce
    out = tmp_path / "thesis"
    _user_results(out)
    before = snapshot(out)
    steps = [Step("one", "Step one", lambda ctx: StepOutput("text", [], {"v": 1}))]
    with pytest.raises(ForeignFolderError, match="--overwrite"):
        reproduce(out, steps=steps, log=lambda m: None)
    assert snapshot(out) == before
    own = tmp_path / "own"
    logs: list[str] = []
    reproduce(own, steps=steps, log=logs.append)
    listed = (own / MANIFEST_NAME).read_text().splitlines()
    assert {"REPORT.md", "cache/one.json"} <= set(listed)
    (own / ".REPORT.md.ehsa_opt-k1l2m3n4.tmp").write_text("partial write of a killed run")
    (own / ".thesis.md.abcdefgh.tmp").write_text("the user's")
    reproduce(own, steps=steps, log=logs.append)  # its own folder: resumes from the cache
    assert any("cached" in m for m in logs) and any("removed" in m for m in logs)
    assert not (own / ".REPORT.md.ehsa_opt-k1l2m3n4.tmp").exists()
    assert (own / ".thesis.md.abcdefgh.tmp").read_text() == "the user's"


def test_discrepancy_into_a_folder_with_the_users_report(tmp_path, capsys, no_work):
    out = tmp_path / "notes"
    out.mkdir()
    (out / "report.md").write_text("my report\n")
    before = snapshot(out)
    data = ROOT / "data/bench_prototype"
    rc, err = run(capsys, "discrepancy", data, "--out", out)
    _refused(rc, err, out, "--overwrite")
    rc, err = run(capsys, "discrepancy", data, "--out", out, "--overwrite")
    _refused(rc, err, out, "report.md was not written by ehsa-opt")
    assert snapshot(out) == before


@pytest.mark.parametrize("argv, name", [
    (("identify", ROOT / "data/bench_prototype"), "identification.json"),
    (("optimize", ROOT / "problems/paper_design.toml"), "result.json"),
    (("sweep", ROOT / "problems/paper_design.toml"), "sweep.csv"),
])
def test_other_commands_refuse_a_users_folder(tmp_path, capsys, argv, name):
    out = tmp_path / "mine"
    out.mkdir()
    (out / name).write_text("mine\n")
    before = snapshot(out)
    rc, err = run(capsys, *argv, "--out", out)
    _refused(rc, err, out, "--overwrite")
    rc, err = run(capsys, *argv, "--out", out, "--overwrite")
    _refused(rc, err, out, f"{name} was not written by ehsa-opt")
    assert snapshot(out) == before


def test_overwrite_adds_beside_the_users_files_and_never_replaces_one(tmp_path):
    out = tmp_path / "shared"
    (out / "figures").mkdir(parents=True)
    (out / "figures/a.png").write_bytes(b"mine")
    with claimed(out, overwrite=True):
        atomic_write_text(out / "figures/b.png", "ours")
        with pytest.raises(ForeignFolderError, match="figures/a.png"):
            atomic_write_text(out / "figures/a.png", "ours")  # a name known only at run time
    assert (out / "figures/a.png").read_bytes() == b"mine"
    # the folder is ours now: a second run needs no --overwrite, replaces its own file and
    # still not the user's
    with claimed(out):
        atomic_write_text(out / "figures/b.png", "ours again")
        with pytest.raises(ForeignFolderError):
            atomic_write_text(out / "figures/a.png", "ours")
    assert (out / "figures/b.png").read_text() == "ours again"
    assert (out / "figures/a.png").read_bytes() == b"mine"
    assert sorted(f.name for f in (out / "figures").iterdir()) == ["a.png", "b.png"]


def test_an_interrupted_first_run_leaves_a_folder_that_is_still_ours(tmp_path):
    """A killed run may leave empty sub-folders (and the lock); the next run takes them."""
    out = tmp_path / "out"
    (out / "figures").mkdir(parents=True)
    (out / ".ehsa_opt.lock").write_text("123\n")
    with claimed(out):
        atomic_write_text(out / "figures/x.csv", "1\n")
    assert (out / MANIFEST_NAME).read_text().splitlines()[1:] == ["figures/x.csv"]
