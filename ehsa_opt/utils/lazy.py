"""Curated room exports resolved on first use (PEP 562 module ``__getattr__``).

A room's ``__init__`` lists its public names and the module each lives in; the module is
imported only when the name is first read, so ``import ehsa_opt.vehicle.road`` does not
pay for the compiled simulation, and a room's ``__init__`` never adds an import cycle.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(package: str, exports: Mapping[str, str]
                 ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for ``package`` exporting ``name`` from ``exports[name]``
    (a module path relative to ``package``, e.g. ``".road"``)."""

    def getattr_(name: str) -> Any:
        where = exports.get(name)
        if where is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(where, package), name)
        globals_ = importlib.import_module(package).__dict__
        globals_[name] = value  # cached: the next read does not come here
        return value

    def dir_() -> list[str]:
        return sorted(set(importlib.import_module(package).__dict__) | set(exports))

    return getattr_, dir_
