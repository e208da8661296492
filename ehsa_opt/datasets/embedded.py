"""Embedded data sets shipped with the package (``ehsa_opt/data``, also reachable as
``data/`` at the top of the repository).

``bench_prototype``
    Synthetic bench data of the Table 1 prototype, paper test matrix, with
    hidden backlash and noise; true parameters in its ``truth.toml``.
``emps``
    The real EMPS ball-screw data (Janot et al. 2019) in bench format;
    ``emps/validation`` holds the pulse validation set.
"""

from __future__ import annotations

from pathlib import Path

from ..physics.params import load_toml

__all__ = ["DATA_ROOT", "embedded_data_dir", "load_truth"]

DATA_ROOT = Path(__file__).resolve().parent.parent / "data"


def embedded_data_dir(name: str = "bench_prototype") -> Path:
    """Path of an embedded data set ('bench_prototype', 'emps', 'emps/validation')."""
    path = DATA_ROOT / name
    if not (path / "bench.toml").is_file():
        known = sorted(p.name for p in DATA_ROOT.iterdir() if (p / "bench.toml").is_file())
        raise FileNotFoundError(f"embedded data set '{name}' not found in {DATA_ROOT} "
                                f"(available: {', '.join(known)})")
    return path


def load_truth(data_dir: str | Path) -> dict | None:
    """The ``truth.toml`` next to synthetic data, or None for measured data."""
    path = Path(data_dir) / "truth.toml"
    return load_toml(path) if path.is_file() else None
