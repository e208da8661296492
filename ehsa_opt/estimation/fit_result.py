"""The result of fitting one parameter set to a group of tests: :class:`FitResult`.

Both fitting procedures of the room return it — the identification's Eq 5 minimax fit
(:func:`~ehsa_opt.estimation.identify.fit_tests`) and the discrepancy workflow's
likelihood fit (:func:`~ehsa_opt.estimation.discrepancy.fit.fit_group`) — so the words
are one: ``success``, ``message``, ``status``, ``parameters``, ``free``, ``objective``,
``nit``, ``starts``, ``seconds`` (as ``scipy.optimize.OptimizeResult``: ``success``,
``message``, ``status``, ``nit``).  The fields that only one procedure fills are optional
and ``None`` (or empty) when the other returns the result.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, fields
from typing import TYPE_CHECKING, Any, Mapping, Sequence

import numpy as np

from ..utils.io import json_safe
from .test_simulation import simulate_tests

if TYPE_CHECKING:
    from matplotlib.figure import Figure

    from ..datasets.bench_format import BenchTest

__all__ = ["FitResult"]


@dataclass(kw_only=True)
class FitResult:
    """One parameter set fitted to a group of tests (mirrors ``scipy.optimize.OptimizeResult``).

    Attributes
    ----------
    success : bool
        True if the kept start converged (IPOPT ``Solve_Succeeded`` or an acceptable
        level; the identification also refuses fits that did not reach the data).
    message : str
        Why it succeeded or failed, in words (starts converged, the statuses met).
    status : str
        Solver return status of the kept start (IPOPT ``return_status``, or the
        least-squares status on a model without state); ``""`` when nothing was solved.
    parameters : dict[str, float]
        Every model parameter by name, in its declared unit (``*_N``, ``*_m_per_s``,
        ``*_Nm``, ``*_rad_per_s``, ``inertia_kg``, …): the fitted ones and the fixed
        ones (NaN, or empty, when no start succeeded).  ``load_ohm`` is left out.
    free : list[str]
        The names that were fitted (the others were fixed or tied).
    objective : float
        The procedure's objective at the kept point (dimensionless): the Eq 5 minimax
        ``t + w·mean(J)`` of the identification, the mean squared noise-normalised
        residual of the likelihood fit.  NaN or inf when no start succeeded.
    nit : int
        Solver iterations of the kept start.
    starts : list[dict]
        One record per start: at least ``status``, ``success``, ``objective``; the
        identification adds ``initial``, ``final``, ``iterations``, ``seconds``.
    records : dict
        What a fit that is not a plain multistart noted, by kind: ``impact_fit`` (the
        impact-aware contact fit), ``simulation_refit`` and ``refinement`` (stages on
        the simulation), ``flexibility`` (the variable-projection grid), ``cut`` (the
        stages the run's safety cap cut).
    seconds : float
        Wall time of the fit (s).
    delta_F, delta_V : float or None
        Identification: paper Eq 5 (as printed) of force and voltage, the max over the
        fitted tests (δ_V None without voltage).
    force_relative_error_percent : float or None
        Identification: ‖F_s − F_e‖₂ / ‖F_e‖₂ over all fitted samples (%).
    per_test : list[dict]
        Identification: ``file``, ``delta_F``, ``delta_V``,
        ``force_relative_error_percent``, ``resolved_percent`` per test.
    history : dict
        Identification: the best start per iteration, ``objective``, ``rms_F``,
        ``rms_V`` (lists) and ``parameters`` (name → list).
    identifiability : dict or None
        Identification: see :func:`~ehsa_opt.estimation.identifiability.fisher_identifiability`.
    path : str
        How the fit was solved: ``"collocation"`` (states are collocation unknowns),
        ``"rigid"`` (no state depends on a free parameter: states integrated once, or a
        model without state, and only the parameters are solved for) or ``"none"`` (no
        fit); the discrepancy workflow's own fits say ``"simulation"`` (refined on the
        forward simulation), ``"variable_projection"`` or ``"impacts"``.
    sse : float or None
        Likelihood fit: sum of squared noise-normalised residuals (dimensionless).
    n_obs : int or None
        Likelihood fit: number of observations (samples × channels) in ``sse``.
    covariance : ndarray or None
        Likelihood fit: covariance of the ``free`` parameters (their units squared):
        Newey–West sandwich on the Gauss–Newton Jacobian (autocorrelated residuals;
        :mod:`ehsa_opt.estimation.covariance`).
    covariance_info : dict or None
        How ``covariance`` was computed: method, N_eff, bandwidth, inflation over the
        independent-samples covariance.
    """

    success: bool
    message: str
    status: str = ""
    parameters: dict[str, float] = field(default_factory=dict)
    free: list[str] = field(default_factory=list)
    objective: float = math.nan
    nit: int = 0
    starts: list[dict] = field(default_factory=list)
    records: dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0
    # the identification's (fit_tests) measures of the fit
    delta_F: float | None = None
    delta_V: float | None = None
    force_relative_error_percent: float | None = None
    per_test: list[dict] = field(default_factory=list)
    history: dict = field(default_factory=dict)
    identifiability: dict | None = None
    path: str = "collocation"
    # the likelihood fit's (fit_group) statistics
    sse: float | None = None
    n_obs: int | None = None
    covariance: np.ndarray | None = None
    covariance_info: dict | None = None

    def __getitem__(self, key: str) -> Any:  # OptimizeResult-like access
        return getattr(self, key)

    def interval(self, name: str, z: float = 1.96) -> tuple[float, float] | None:
        """``value ± z·sd`` of a fitted parameter from :attr:`covariance` (~95 % at the
        default ``z``), in the parameter's unit; None if it was not fitted, there is no
        covariance, or the data do not determine it."""
        if self.covariance is None or name not in self.free:
            return None
        k = self.free.index(name)
        var = float(self.covariance[k, k])
        if not math.isfinite(var):
            return None  # not determined by the data
        sd = math.sqrt(max(var, 0.0))
        v = self.parameters[name]
        return (v - z * sd, v + z * sd)

    def summary(self) -> str:
        """Status, the measures of the fit and the parameters found."""
        if not self.success:
            return f"fit FAILED ({self.status}): {self.message}"
        if self.delta_F is not None:
            dv = f"{self.delta_V:.4f}" if self.delta_V is not None else "—"
            head = (f"fit converged ({self.status}, {self.nit} iterations, {self.path}): δ_F "
                    f"{self.delta_F:.4f}, δ_V {dv}, force error "
                    f"{self.force_relative_error_percent:.2f} %")
        else:
            head = (f"fit converged ({self.status}): objective {self.objective:.6g} "
                    f"over {self.n_obs} observations")
        lines = [head]
        for k, v in self.parameters.items():
            ci = self.interval(k)
            band = f"  (95 %: {ci[0]:.6g} … {ci[1]:.6g})" if ci is not None else ""
            lines.append(f"  {k} = {v:.6g}{band}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        """Every attribute as standard-JSON types (arrays as nested lists, NaN and inf as
        None); :meth:`from_dict` reloads it."""
        return json_safe({f.name: getattr(self, f.name) for f in fields(self)})

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> "FitResult":
        """Inverse of :meth:`to_dict` (a NaN stored as None comes back as NaN in
        ``parameters`` and ``objective``; unknown keys are refused)."""
        names = {f.name for f in fields(cls)}
        unknown = sorted(set(d) - names)
        if unknown:
            raise ValueError(f"FitResult.from_dict: unknown key(s) {', '.join(unknown)} "
                             f"(known: {', '.join(sorted(names))})")
        kw = dict(d)
        kw["parameters"] = {k: (math.nan if v is None else float(v))
                            for k, v in (d.get("parameters") or {}).items()}
        for k in ("objective", "seconds"):
            if k in kw:
                kw[k] = math.nan if kw[k] is None else float(kw[k])
        if kw.get("covariance") is not None:
            kw["covariance"] = np.array([[math.nan if x is None else x for x in row]
                                         for row in kw["covariance"]], dtype=float)
        return cls(**kw)

    def to_json(self) -> str:
        """:meth:`to_dict` as JSON text."""
        return json.dumps(self.to_dict(), indent=1, allow_nan=False)

    @classmethod
    def from_json(cls, text: str) -> "FitResult":
        """Reload a result written by :meth:`to_json`."""
        return cls.from_dict(json.loads(text))

    def plot(self, ax: Any = None, tests: Sequence[BenchTest] | None = None,
             harvester: Any = None, **kw: Any) -> list[Figure]:
        """Figures 8–9 of an identification fit (and 11 when ``tests`` and ``harvester``
        are given: the first test simulated at these parameters, ``kw`` to
        :func:`~ehsa_opt.estimation.test_simulation.simulate_tests`); writes nothing.
        ``ax`` is not used (several figures); it is accepted for the common protocol."""
        if not self.history:
            raise ValueError("FitResult.plot: this result has no iteration history (only "
                             "the identification's fit_tests records one)")
        from ..plots import identify as P
        test = pred = None
        if tests is not None and harvester is not None and self.success:
            test = tests[0]
            pred = simulate_tests(tests[:1], harvester, self.parameters, **kw)[0]
        return P.fit_result(self, test, pred)

