"""The rooms' curated exports: every name in ``__all__`` resolves, to the object its module
defines, and a name not exported is refused."""

import importlib

import pytest


@pytest.mark.parametrize("room", ["ehsa_opt.vehicle", "ehsa_opt.estimation",
                                  "ehsa_opt.vehicle.fast_path"])
def test_every_exported_name_resolves(room: str) -> None:
    pkg = importlib.import_module(room)
    assert pkg.__all__ and len(set(pkg.__all__)) == len(pkg.__all__)
    for name in pkg.__all__:
        value = getattr(pkg, name)
        home = getattr(value, "__module__", None)
        if home is not None and home.startswith("ehsa_opt."):
            assert getattr(importlib.import_module(home), name) is value
        assert name in dir(pkg)


def test_unknown_name_is_refused() -> None:
    import ehsa_opt.vehicle as vehicle
    with pytest.raises(AttributeError, match="no attribute 'no_such_name'"):
        vehicle.no_such_name  # noqa: B018


def test_fast_path_entry_is_the_linearisation_driver() -> None:
    from ehsa_opt.vehicle import fast_path, friction_metrics
    from ehsa_opt.vehicle.fast_path.linearisation import friction_metrics as driver
    assert friction_metrics is driver is fast_path.friction_metrics
