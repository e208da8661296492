"""Data room: the bench data format (strict loader, atomic writer), the EMPS
converter, the synthetic bench generator, the embedded data sets and the quarter-car
problem files. Imports only :mod:`ehsa_opt.physics` and :mod:`ehsa_opt.utils`."""

__all__: list[str] = []
