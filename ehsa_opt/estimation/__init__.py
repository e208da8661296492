"""Estimation room: friction identification (paper §3, Eq 5 minimax), identifiability,
the data-supported friction bounds, the rod friction law and the model-discrepancy
workflow (:mod:`.discrepancy`). Imports physics, datasets and utils.

The names below are the room's public entry points; each is imported from its module on
first use.
"""

from __future__ import annotations

from ..utils.lazy import lazy_exports

_EXPORTS = {
    **dict.fromkeys(["FitResult"], ".fit_result"),
    **dict.fromkeys(["fit_tests", "IdentifyOptions", "Prediction",
                     "IdentificationReport", "PARAMETER_BOUNDS", "START_RANGES"], ".identify"),
    **dict.fromkeys(["simulate_tests"], ".test_simulation"),
    **dict.fromkeys(["fisher_identifiability"], ".identifiability"),
    **dict.fromkeys(["FrictionBounds", "friction_bounds", "paper_friction_sets",
                     "identification_dict", "identification_json"], ".bounds"),
    **dict.fromkeys(["FrictionSamples", "RodLawFit", "friction_samples", "rod_law_fit"],
                    ".rod_law"),
    **dict.fromkeys(["HAC", "hac_covariance", "effective_sample_size"], ".covariance"),
    **dict.fromkeys(["run_discrepancy", "DiscrepancyResult", "DiscrepancySettings"],
                    ".discrepancy"),
}

__all__ = ["HAC", "PARAMETER_BOUNDS", "START_RANGES", "DiscrepancyResult", "DiscrepancySettings",
           "FitResult", "FrictionBounds", "FrictionSamples", "IdentificationReport",
           "IdentifyOptions", "Prediction", "RodLawFit", "effective_sample_size",
           "fisher_identifiability", "fit_tests", "friction_bounds", "friction_samples",
           "hac_covariance", "identification_dict", "identification_json", "paper_friction_sets", "rod_law_fit",
           "run_discrepancy", "simulate_tests"]
assert set(__all__) == set(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
