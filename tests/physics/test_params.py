import math

import pytest

from ehsa_opt.physics.params import (FrictionParams, HarvesterParams, ParameterError, RoadParams,
                             VehicleParams, from_mapping)


def test_unknown_key_suggests_nearest_name():
    with pytest.raises(ParameterError, match="did you mean 'lead_mm_per_rev'"):
        from_mapping(HarvesterParams, {"lead_mm_per_revv": 5.0}, "p.toml [harvester]")


def test_error_names_location_and_unit():
    with pytest.raises(ParameterError, match=r"p.toml \[vehicle\].*sprung_mass_kg.*> 0"):
        from_mapping(VehicleParams, {"sprung_mass_kg": -1.0}, "p.toml [vehicle]")


def test_non_number_rejected():
    with pytest.raises(ParameterError, match="must be a number"):
        HarvesterParams(lead_mm_per_rev="5")


def test_friction_breakaway_below_coulomb_rejected():
    with pytest.raises(ParameterError, match="nut_breakaway_N .* must be >= nut_coulomb_N"):
        FrictionParams(nut_breakaway_N=10.0, nut_coulomb_N=20.0)


def test_zero_speed_rejected_and_class_normalised():
    with pytest.raises(ParameterError, match="speed_km_per_h"):
        RoadParams(speed_km_per_h=0.0)
    assert RoadParams(iso_class="c").iso_class == "C"
    assert math.isclose(RoadParams(iso_class="C").roughness_m3, 256e-6)


def test_unknown_preset():
    with pytest.raises(ParameterError, match="did you mean 'passenger_car'"):
        VehicleParams.preset("pasenger_car")


def test_from_design_speed_constant():
    h = HarvesterParams.from_design(250.0, 7.0, 29.8, 75.0)
    assert math.isclose(h.voltage_constant_Vs_per_rad, 60 / (2 * math.pi * 29.8))
    assert math.isclose(h.total_inertia_gcm2, 250.0)
    assert math.isclose(h.speed_constant_rpm_per_V, 29.8)


def test_open_circuit_load_allowed_but_nan_refused():
    h = HarvesterParams(load_ohm=math.inf)
    assert h.equivalent_damping_Ns_per_m(10.0) == 0.0
    with pytest.raises(ParameterError, match="not finite"):
        HarvesterParams(load_ohm=math.nan)
    with pytest.raises(ParameterError, match="not finite"):
        HarvesterParams(lead_mm_per_rev=math.inf)
