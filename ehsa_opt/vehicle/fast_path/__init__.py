"""The friction-aware fast path: the quarter car's metrics with the friction in the loop,
vectorised over designs, without a time-domain simulation.

One entry, :func:`friction_metrics` (same inputs and keys as the exact frictionless
:func:`ehsa_opt.vehicle.frequency_path.linear_metrics`, plus the friction).  How it
works, part by part:

* :mod:`.linearisation` — stochastic equivalent linearisation of the friction law and
  the driver :func:`friction_metrics`;
* :mod:`.band_variances` — the linear quarter car's band-limited variances in closed form
  by residues of its 5-pole transfer functions, poles tracked as the friction damping
  changes; :mod:`.polynomials` — the batched polynomial arithmetic and W_k it uses;
* :mod:`.fixed_point` — the per-design fixed point σ = σ_lin(c_f(σ)) by secants of a
  one-mode model;
* :mod:`.sticking` — the non-Gaussian sticking correction by stochastic averaging;
* :mod:`.residual_force` — the response to the friction's non-linear residual force
  F_f(v) − c_f v under Gaussian closure;
* :mod:`.validation` — the fast path against the time-domain simulation
  (:mod:`ehsa_opt.vehicle.simulate`); not imported here, since the simulation itself
  reads the fast path (its friction-coverage warning): import it as
  ``ehsa_opt.vehicle.fast_path.validation``.
"""

from .band_variances import QuarterCarPolynomials
from .linearisation import (friction_array, friction_equivalent_damping_Ns_per_m, friction_metrics,
                            law_equivalent_damping)
from .residual_force import residual_variances
from .sticking import averaged_damping

__all__ = ["QuarterCarPolynomials", "averaged_damping", "friction_array",
           "friction_equivalent_damping_Ns_per_m", "friction_metrics", "law_equivalent_damping",
           "residual_variances"]
