"""The identified base model the search starts from: its fit (the static friction law;
the dynamic law is a member offered on it, :mod:`.members.dynamic_law`) on the fit
tests, its simulated outputs on every test, the localisation of its residual and its
error."""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..fit_result import FitResult
from .evidence import effective_samples, force_error_percent
from .fit import fit_group
from .localise import Localisation, localise
from .prepared import decimated, decimation_factor
from .results import DiscrepancySettings
from .rig import Rig, linear_baseline, predict
from .search import SearchState, SearchTests
from .candidates import CANDIDATES

__all__ = ["Baseline", "fit_baseline", "simulate_base", "baseline_decimation",
           "BASELINE_MAX_SAMPLES", "CANDIDATE_MAX_SAMPLES"]


@dataclass
class Baseline:
    """The identified base model: its fit, simulated outputs on the fit and held-out
    tests, effective sample sizes, the localisation of its residual and its
    relative force error on the evaluation tests (%)."""

    fit: FitResult
    rig: Rig
    fit_pred: list
    held_pred: list
    n_eff_fit: float
    n_eff_held: float
    localisation: Localisation
    error: float
    law_note: str = ""
    #: The static law's simulated outputs on the fit tests when the dynamic law was
    #: adopted (a record member's start: its own lag is not yet taken by the bristles).
    static_fit_pred: list | None = None

    def state(self, settings: DiscrepancySettings) -> SearchState:
        """The search's start: the base model, every catalogue candidate remaining."""
        return SearchState(self.rig, dict(self.fit.parameters), self.fit_pred, self.held_pred,
                           self.n_eff_fit, self.n_eff_held, self.error, [], [],
                           [n for n in settings.candidates if n in CANDIDATES])


def fit_baseline(tests: SearchTests, settings: DiscrepancySettings, say) -> Baseline:
    """Identify the base model on the fit tests, simulate it on every test and localise
    its residual.

    The static law is fitted from a linear least-squares start.  The dynamic (LuGre)
    law is not decided here: it is the first member offered on this model
    (:class:`~.members.dynamic_law.DynamicLawMember`), judged like every member."""
    rig, fit_pts, held_pts = tests.rig, tests.fit_pts, tests.held_pts
    k = baseline_decimation(fit_pts, rig)
    fit_dec = [decimated(pt, k) for pt in fit_pts]
    base = fit_group(fit_dec, rig, [linear_baseline(fit_pts, rig)], max_iter=settings.max_iter)
    if not base.parameters:
        raise RuntimeError(f"baseline identification failed: {base.message}")
    say(f"baseline: {base.message}, chi2/N {base.objective:.3g} ({base.seconds:.1f} s"
        + (f"; collocation on every {k}th sample of the fit tests" if k > 1 else "") + ")")
    fit_pred, held_pred, n_eff_fit, n_eff_held = simulate_base(tests, rig, base)
    loc0 = localise(fit_pts + held_pts, fit_pred + held_pred,
                    lead_m_per_rad=tests.lead_m_per_rad)
    err0 = force_error_percent(tests.eval_pts, held_pred or fit_pred)
    law_note = ("friction law: static" + ("" if settings.dynamic_friction else
                " (the dynamic law not offered: DiscrepancySettings.dynamic_friction, "
                "discrepancy --dynamic-friction)"))
    return Baseline(base, rig, fit_pred, held_pred, n_eff_fit, n_eff_held, loc0, err0,
                    law_note)


def simulate_base(tests: SearchTests, rig: Rig, fit: FitResult) -> tuple:
    """A base model's simulated outputs on the fit and held-out tests and the effective
    sample sizes of its residual."""
    fit_pred = predict(tests.fit_pts, rig, fit.parameters)
    held_pred = predict(tests.held_pts, rig, fit.parameters) if tests.held_pts else []
    n_eff_fit = effective_samples(tests.fit_pts, fit_pred)
    n_eff_held = effective_samples(tests.held_pts, held_pred) if tests.held_pts else math.nan
    return fit_pred, held_pred, n_eff_fit, n_eff_held


#: The baseline's collocation fit uses at most this many samples of the fit tests (every
#: k-th sample, :func:`~.prepared.decimated`).  The cost of building the collocation NLP
#: grows with the square of its samples (≈ 50 s for 15 000, 7 s for 5 000 on the 2-core
#: machine), while the rigid model's only state, the winding current, is quasi-static
#: at any such step (L/R ≈ 0.2 ms): the decimated fit differs from the full one by the
#: sampling error of fewer samples (held-out error 11.75 % full, 11.79 % on every 4th
#: sample, on a 16-test mixed campaign).  Every prediction, error and statistic the
#: decision uses is a simulation on every sample.
BASELINE_MAX_SAMPLES = 4000


#: A cap on the samples of the candidate fits (collocation on every sample: an effect may
#: ring or ripple at hundreds of Hz): ``max_fit_tests`` spread over the fit tests, fewer
#: while they hold more (:func:`~.split.spread_within`); None: no cap.  Off: a cap of 6000
#: samples left the embedded data's full configuration with two fit tests, and its backlash
#: fit then depended on the platform's floating point (gap +0.1 % on one build of the same
#: package versions, +12.8 % on another).  The candidates are judged, as always, by
#: simulation on every fit and held-out test.
CANDIDATE_MAX_SAMPLES: int | None = None


def baseline_decimation(fit_pts, rig: Rig) -> int:
    """The step k of :data:`BASELINE_MAX_SAMPLES` for a model with states (collocation);
    1 for a model without (a least-squares fit, whose cost is linear)."""
    return decimation_factor(fit_pts, BASELINE_MAX_SAMPLES) if rig.model().n_states else 1
