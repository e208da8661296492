"""Paper §4.1 studies: quick runs that check physics, not just that they run."""

import numpy as np
import pytest

from ehsa_opt.datasets.friction_source import FrictionSets
from ehsa_opt.physics.params import (
    FRICTION_NAMES,
    FrictionParams,
    HarvesterParams,
    RoadParams,
    VehicleParams,
)
from ehsa_opt.vehicle.studies import (force_velocity_loops, friction_cases, paper_optimum_harvester,
                              road_study, stepped_sine_response)


def test_friction_cases_use_identification_when_given():
    default = friction_cases(None)
    assert default.cases["none"] is None
    assert default.cases["min"].nut_coulomb_N == pytest.approx(
        0.3 * default.cases["max"].nut_coulomb_N)
    assert "TRUE friction" in default.source
    lo = default.cases["min"]
    hi = FrictionParams(**{k: getattr(default.cases["max"], k) * (2 if "velocity" not in k
                                                                  else 1)
                           for k in FRICTION_NAMES})
    sets = FrictionSets(lo, default.cases["max"], hi, "data-supported")
    got = friction_cases(sets)
    assert got.source.startswith("identified, data-supported")
    assert got.cases["max"].nut_coulomb_N == pytest.approx(2 * default.cases["max"].nut_coulomb_N)
    # the step cache's dict gives the same cases back
    again = friction_cases(FrictionSets.from_dict(sets.to_dict()))
    assert again.cases == got.cases
    # the paper's per-parameter sets only when asked for, and only when they exist
    assert friction_cases(sets, "paper").source == default.source
    paper = FrictionSets(lo, lo, hi, "data-supported", paper_min=hi, paper_max=hi)
    assert friction_cases(paper, "paper").cases["min"] == hi
    with pytest.raises(ValueError, match="'data' or 'paper'"):
        friction_cases(sets, "both")


def test_force_velocity_equivalent_damping():
    fc = friction_cases(None)
    h = HarvesterParams()
    study = force_velocity_loops(h, fc)
    c = study.equivalent_damping_Ns_per_m
    assert c[("open circuit", "min")] < c[("open circuit", "max")]
    # short circuit = electrical K²/(r² R_i) (inductance negligible at 1.5 Hz) + friction
    elec = h.equivalent_damping_Ns_per_m(2 * np.pi * 1.5, 0.0)
    for case in ("min", "max"):
        assert c[("short circuit", case)] - c[("open circuit", case)] == pytest.approx(elec,
                                                                                       rel=0.02)


def test_stepped_sine_frictionless_matches_linear_transmissibility():
    fc = friction_cases(None)
    vehicle, h = VehicleParams(), HarvesterParams(load_ohm=47.0)
    # both resonances (body ~1.1 Hz, wheel hop ~8 Hz) and the band's ends, three loads
    freqs = np.array([0.5, 1.1, 3.0, 7.95, 20.0])
    loads = [15.0, 47.0, 109.0]
    study = stepped_sine_response(vehicle, h, fc, loads, freqs, amplitude_m=0.01)
    # the exact response written out independently: |X2/X0| from Eqs 2–3 with the
    # full impedance, V_g = R_e K_e s (X2 − X1) / (r (R + s L))
    from ehsa_opt.physics.harvester import equivalent_impedance
    w = 2 * np.pi * freqs
    s = 1j * w
    none = study.cases.index("none")
    for j, load in enumerate(loads):
        hj = h.replace(load_ohm=load)
        dyn = vehicle.suspension_stiffness_N_per_m + s * equivalent_impedance(hj, w)
        a11 = vehicle.sprung_mass_kg * s ** 2 + dyn
        det = a11 * (vehicle.unsprung_mass_kg * s ** 2 + dyn
                     + vehicle.tyre_stiffness_N_per_m) - dyn ** 2
        x2 = vehicle.tyre_stiffness_N_per_m * dyn / det
        x1 = vehicle.tyre_stiffness_N_per_m * a11 / det
        vg = load * hj.voltage_constant_Vs_per_rad * s * (x2 - x1) / (
            hj.lead_m_per_rad * (hj.total_resistance_ohm() + s * hj.inductance_H))
        assert np.allclose(study.sprung_transmissibility[none, j], np.abs(x2), rtol=0.01)
        assert np.allclose(study.voltage_amplitude_V[none, j], 0.01 * np.abs(vg), rtol=0.01)
    assert study.frictionless_deviation() < 0.01
    # the body-mode peak of the lightest-damped load is reached (a transient start or a
    # short settling time gives it up to 25 % low)
    assert study.sprung_transmissibility[none, 2, 1] == pytest.approx(12.42, rel=0.01)
    assert study.settled.all() and np.all(study.amplitude_change < study.tolerance)
    # friction lowers the generator voltage at every frequency
    mx = study.cases.index("max")
    assert np.all(study.voltage_amplitude_V[mx] < study.voltage_amplitude_V[none])


def test_stepped_sine_flags_points_that_do_not_settle():
    fc = friction_cases(None)
    study = stepped_sine_response(VehicleParams(), HarvesterParams(), fc, [109.0], [1.1],
                                  tolerance=1e-6, max_time_s=2.0)
    assert not study.settled[study.cases.index("max")].all()
    with pytest.raises(ValueError, match="tolerance"):
        stepped_sine_response(VehicleParams(), HarvesterParams(), fc, [47.0], [1.0],
                              tolerance=0.5)


def test_road_study_retunes_to_equal_slopes_and_friction_costs_power():
    fc = friction_cases(None)
    study = road_study(VehicleParams(), HarvesterParams(load_ohm=10.0), fc,
                       RoadParams(length_m=150.0), n_loads=10)
    assert all(study.reachable)
    assert np.allclose(study.slopes_Ns_per_m, study.target_slope_Ns_per_m, rtol=0.02)
    assert study.loads_ohm[0] < study.loads_ohm[1] < study.loads_ohm[2]
    p = study.average_power_W
    assert p[0] > p[1] > p[2]
    fixed = road_study(VehicleParams(), paper_optimum_harvester(), fc, RoadParams(length_m=150.0),
                       retune=False)
    assert fixed.loads_ohm == [75.0, 75.0, 75.0]


def test_invalid_road_results_are_flagged_in_the_table_and_left_out_of_conclusions():
    """The single seater with the prototype: road holding > 1 (tyre leaves the ground)."""
    from ehsa_opt.pipeline.quarter_car_report import road_study_conclusions
    from ehsa_opt.vehicle.validity import check_validity
    fc = friction_cases(None)
    vehicle = VehicleParams.preset("single_seater")
    study = road_study(vehicle, HarvesterParams(load_ohm=10.0), fc, RoadParams(length_m=200.0),
                       n_loads=6)
    m = study.sim.metrics
    assert np.all(m["road_holding"] > 1.0)
    validity = check_validity(m, stroke_limit_m=vehicle.stroke_limit_m)
    assert not validity.valid.any()
    assert all(validity.codes(i) == ["tyre_lift"] for i in range(3))
    assert validity.cell(0).startswith("**INVALID: tyre leaves the ground")
    text = road_study_conclusions(study, validity)
    assert "No conclusion" in text and "hardly changes" not in text
    # the passenger car on the same road is valid and concluded on
    car = road_study(VehicleParams(), HarvesterParams(load_ohm=10.0), fc,
                     RoadParams(length_m=200.0), n_loads=6)
    ok = check_validity(car.sim.metrics, stroke_limit_m=0.1)
    assert ok.all_valid and ok.cell(1) == "valid"
    assert "comfort" in road_study_conclusions(car, ok)


def test_validity_stroke_limit_fast_path_region_and_joined_flags():
    from ehsa_opt.vehicle.validity import (GAUSSIAN_PEAK_FACTOR, Validity, ValidityFlag,
                                           check_validity, register_check, VALIDITY_CHECKS)
    # time domain: the peak stroke; frequency path: GAUSSIAN_PEAK_FACTOR x rms
    v = check_validity({"road_holding": [0.2, 0.2], "peak_stroke_m": [0.09, 0.12]},
                       stroke_limit_m=0.1)
    assert v.valid.tolist() == [True, False] and v.codes(1) == ["stroke_limit"]
    assert "120 mm (peak) beyond the 100 mm limit" in v.cell(1)
    rms = 0.1 / GAUSSIAN_PEAK_FACTOR
    v = check_validity({"road_holding": [0.2, 0.2], "stroke_rms_m": [0.99 * rms, 1.01 * rms]},
                       stroke_limit_m=0.1)
    assert v.valid.tolist() == [True, False]
    # fast path outside its validated region, on the design variables
    v = check_validity({"road_holding": [0.2, 0.2]}, design={"load_ohm": [50.0, 5e3]},
                       fast_path_region={"load_ohm": (1.0, 1e3)})
    assert v.valid.tolist() == [True, False] and v.codes(1) == ["fast_path_region"]
    # another check joins the registry; flags from elsewhere join a Validity
    register_check("test_extra", lambda m, ctx: ["extra" if x > 0.1 else None
                                                 for x in m["road_holding"]])
    try:
        v = check_validity({"road_holding": [0.2, 1.2]})
        assert v.codes(0) == ["test_extra"] and v.codes(1) == ["tyre_lift", "test_extra"]
    finally:
        del VALIDITY_CHECKS["test_extra"]
    other = Validity(((ValidityFlag("friction_range", "friction extrapolated"),), ()))
    j = check_validity({"road_holding": [0.2, 1.5]}).join(other)
    assert j.codes(0) == ["friction_range"] and j.codes(1) == ["tyre_lift"]
    with pytest.raises(ValueError, match="road_holding"):
        check_validity({"power_W": [1.0]})


def test_validity_flags_the_fast_path_beyond_its_indicator():
    from ehsa_opt.vehicle.fast_path.linearisation import friction_metrics
    from ehsa_opt.vehicle.fast_path.validation import scaled_friction
    from ehsa_opt.vehicle.validity import FAST_PATH_MAX_CORRECTION, check_validity
    data = friction_cases(None).cases["max"]
    # class C at 100 km/h with half the data's friction: the strut hardly sticks;
    # class B at 30 km/h with 4x: it sticks for long stretches (correction ~5-8 %)
    for road, scale, flagged in ((RoadParams("C", 100.0), 0.5, False),
                                 (RoadParams("B", 30.0), 4.0, True)):
        m = friction_metrics(VehicleParams(), road, {"load_ohm": np.array([5.0, 47.0])},
                             scaled_friction(data, scale))
        corr = m["friction_damping_gaussian_Ns_per_m"] / m["friction_damping_Ns_per_m"] - 1
        assert np.all((corr > FAST_PATH_MAX_CORRECTION) == flagged)
        v = check_validity(m)
        assert all(("fast_path_indicator" in v.codes(k)) == flagged for k in range(2))


def test_fig13_fig14_state_the_share_beyond_the_identified_range_and_warn():
    """The stepped sine and the force-velocity loops measure their stroke velocities
    against the identified range: a sine stroke of amplitude V spends (2/π) arccos(v/V)
    of its time above v; above the limit the report's cell and the warning say so."""
    from ehsa_opt.pipeline.coverage_report import range_cell
    from ehsa_opt.vehicle.coverage import OUT_OF_RANGE_LIMIT, coverage_warning
    from ehsa_opt.vehicle.frequency_path import linear_frequency_response
    fc = friction_cases(None)
    vehicle, h = VehicleParams(), HarvesterParams(load_ohm=47.0)
    f, amp = 1.1, 0.01
    lin = linear_frequency_response(vehicle, h, [f])
    v_amp = 2 * np.pi * f * amp * abs(lin["x2"][0] - lin["x1"][0])
    v_id = 0.1 * v_amp
    study = stepped_sine_response(vehicle, h, fc, [47.0], [f], amplitude_m=amp,
                                  identified_range_m_per_s=v_id)
    none, mx = study.cases.index("none"), study.cases.index("max")
    t = study.out_of_range_time_fraction
    assert t[none, 0, 0] == pytest.approx(2 / np.pi * np.arccos(0.1), abs=0.01)
    assert np.isnan(study.out_of_range_friction_energy_fraction[none, 0, 0])
    e = study.out_of_range_friction_energy_fraction[mx, 0, 0]
    assert t[mx, 0, 0] > OUT_OF_RANGE_LIMIT and e > t[mx, 0, 0]  # fast strokes carry more
    assert "⚠" in range_cell(t[mx, 0, 0], e)
    assert coverage_warning({"time_fraction": t[mx, 0, 0], "energy_fraction": e}, v_id)
    # far above every stroke: nothing out of range, no warning, no mark
    calm = stepped_sine_response(vehicle, h, fc, [47.0], [f], amplitude_m=amp,
                                 identified_range_m_per_s=10 * v_amp)
    assert np.all(calm.out_of_range_time_fraction == 0.0)
    assert "⚠" not in range_cell(calm.out_of_range_time_fraction[mx, 0, 0],
                                 calm.out_of_range_friction_energy_fraction[mx, 0, 0])
    loops = force_velocity_loops(h, fc, identified_range_m_per_s=0.05)
    peak = 2 * np.pi * 1.5 * 0.015
    for key, (tt, ee) in loops.out_of_range.items():
        assert tt == pytest.approx(2 / np.pi * np.arccos(0.05 / peak), abs=0.01), key
        assert coverage_warning({"time_fraction": tt, "energy_fraction": ee}, 0.05)
    assert not any(max(x) > 0 for x in force_velocity_loops(
        h, fc, identified_range_m_per_s=1.0).out_of_range.values())
    import matplotlib.pyplot as plt
    for fig in (study.plot(), loops.plot()):
        plt.close(fig)
