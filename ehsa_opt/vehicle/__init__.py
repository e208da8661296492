"""Vehicle room: ISO 8608 roads (:mod:`.road`), ISO 2631 W_k weighting (:mod:`.iso2631`),
the exact frequency-domain path (:mod:`.frequency_path`), the friction-aware fast path
(:mod:`.fast_path`), the compiled time-domain path (:mod:`.simulate`), validity flags
(:mod:`.validity`), intervals over road realisations (:mod:`.uncertainty`), friction coverage (:mod:`.coverage`), the paper's §4.1 studies
(:mod:`.studies`) and the friction law's effect on them (:mod:`.friction_law_study`). Imports physics, datasets, estimation results and utils.

The names below are the room's public entry points; each is imported from its module on
first use.
"""

from __future__ import annotations

from ..utils.lazy import lazy_exports

_EXPORTS = {
    **dict.fromkeys(["RoadProfile", "road_psd_m3", "road_velocity_psd", "dissipation_bound_W",
                     "synthesize_road", "load_profile_csv", "road_profile"], ".road"),
    **dict.fromkeys(["wk_exact", "wk_abs2", "wk_filter", "weighted_rms_fft"], ".iso2631"),
    **dict.fromkeys(["METRIC_KEYS", "DESIGN_KEYS", "design_arrays", "linear_metrics",
                     "linear_frequency_response"], ".frequency_path"),
    **dict.fromkeys(["friction_metrics"], ".fast_path"),
    **dict.fromkeys(["QuarterCarSimulation", "simulate_quarter_car", "simulate_batch",
                     "RoadHoldingWarning", "FrictionRangeWarning"], ".simulate"),
    **dict.fromkeys(["FrictionCases", "friction_cases", "FrequencyResponseStudy",
                     "stepped_sine_response", "ForceVelocityStudy", "force_velocity_loops",
                     "RoadStudy", "road_study"], ".studies"),
    **dict.fromkeys(["Validity", "ValidityFlag", "check_validity", "SampleLimits",
                     "exceedance_fractions"], ".validity"),
    **dict.fromkeys(["Interval", "RoadIntervals", "road_intervals", "seed_interval",
                     "batch_means_interval", "format_interval"], ".uncertainty"),
    **dict.fromkeys(["design_coverage"], ".coverage"),
    **dict.fromkeys(["FrictionLawEffect", "friction_law_effect"], ".friction_law_study"),
    **dict.fromkeys(["SimulationEstimate", "estimate_simulation"], ".resources"),
}

__all__ = ["DESIGN_KEYS", "METRIC_KEYS", "ForceVelocityStudy", "FrequencyResponseStudy",
           "FrictionCases", "FrictionLawEffect", "FrictionRangeWarning", "Interval", "RoadIntervals",
           "SampleLimits", "batch_means_interval", "exceedance_fractions", "format_interval",
           "road_intervals", "seed_interval", "QuarterCarSimulation", "RoadHoldingWarning",
           "RoadProfile", "RoadStudy", "SimulationEstimate", "Validity", "ValidityFlag",
           "check_validity", "design_arrays", "design_coverage", "dissipation_bound_W",
           "estimate_simulation", "force_velocity_loops", "friction_cases",
           "friction_law_effect", "friction_metrics",
           "linear_frequency_response", "linear_metrics", "load_profile_csv", "road_profile",
           "road_psd_m3", "road_study", "road_velocity_psd", "simulate_batch",
           "simulate_quarter_car", "stepped_sine_response", "synthesize_road", "weighted_rms_fft",
           "wk_abs2", "wk_exact", "wk_filter"]
assert set(__all__) == set(_EXPORTS)
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS)
