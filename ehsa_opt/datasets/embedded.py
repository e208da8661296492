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
    """The ``truth.toml`` next to synthetic data, or None for measured data.

    Validated as data before anyone uses it: ``[friction]`` a complete friction set,
    ``[effects.NAME]`` known effects with their own parameters as finite numbers.

    Raises
    ------
    ParameterError
        Naming ``truth.toml``, the table or key, and the fix.
    """
    import math

    from ..physics.components import COMPONENTS
    from ..physics.params import ParameterError, check_keys
    from .friction_source import friction_set
    path = Path(data_dir) / "truth.toml"
    if not path.is_file():
        return None
    doc = load_toml(path)
    fix = ("regenerate the data with `ehsa-opt bench generate`, or delete truth.toml if the "
           "data are measured")
    if not isinstance(doc.get("friction"), dict):
        raise ParameterError(f"{path}: missing [friction] table (the true friction of the "
                             f"synthetic data); {fix}")
    friction_set(doc["friction"], f"{path} [friction]")
    effects = doc.get("effects", {})
    check_keys(effects, COMPONENTS, f"{path} [effects]")
    for name, values in effects.items():
        where = f"{path} [effects.{name}]"
        check_keys(values, [q.name for q in COMPONENTS[name].parameters], where)
        for key, v in values.items():
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise ParameterError(f"{where}: {key} = {v!r} is not a finite number; {fix}")
    return doc
