"""Recorded paths that do not depend on the machine: package files by their package path,
a folder's own references relative to it."""

from __future__ import annotations

from pathlib import Path

from ehsa_opt.datasets.embedded import embedded_data_dir
from ehsa_opt.utils.io import display_path, relative_path


def test_package_files_are_recorded_by_their_package_path(tmp_path):
    assert display_path(embedded_data_dir()) == "ehsa_opt/data/bench_prototype"
    assert display_path(tmp_path / "mine.toml") == str(tmp_path / "mine.toml")
    assert display_path("problem.toml") == "problem.toml"


def test_relative_path_reads_back_from_the_folder(tmp_path):
    data = tmp_path / "a" / "data"
    out = tmp_path / "b" / "c"
    data.mkdir(parents=True)
    out.mkdir(parents=True)
    rel = relative_path(data, out)
    assert rel == "../../a/data" and not Path(rel).is_absolute()
    assert (out / rel).resolve() == data.resolve()
