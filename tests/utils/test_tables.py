"""Tidy tables: units from the column names, CSV round trip at full precision, a
DataFrame with its units when pandas is installed."""

from __future__ import annotations

import numpy as np
import pytest

from ehsa_opt.utils.tables import csv_to_columns, table_to_csv, tidy_table, unit_of


def test_units_come_from_the_names() -> None:
    assert unit_of("power_W") == "W" and unit_of("load_ohm") == "ohm"
    assert unit_of("lead_mm_per_rev") == "mm/rev" and unit_of("speed_km_per_h") == "km/h"
    assert unit_of("comfort_weighted_rms_m_s2") == "m/s^2"
    assert unit_of("speed_constant_rpm_per_V") == "rpm/V"  # not "V"
    assert unit_of("comfort") == "-" and unit_of("motor", labels=("motor",)) == ""


def test_csv_round_trip_is_exact() -> None:
    cols = {"motor": np.array(["a", "b"], dtype=object), "power_W": [1 / 3, 2e-17],
            "feasible": [True, False]}
    back = csv_to_columns(table_to_csv(cols), "t.csv")
    assert list(back["motor"]) == ["a", "b"]
    assert back["power_W"].tolist() == [1 / 3, 2e-17]
    with pytest.raises(ValueError, match="t.csv row 3: 1 fields, the header has 2"):
        csv_to_columns("a,b\n1,2\n3\n", "t.csv")


def test_table_is_a_frame_with_units_or_a_dict() -> None:
    with pytest.raises(ValueError, match="different lengths"):
        tidy_table({"a": [1, 2], "b": [1]})
    t = tidy_table({"load_ohm": [1.0, 2.0], "peak_current_A": [3.0, 4.0]},
                   {"peak_current_A": "A (peak)"})
    try:
        import pandas  # noqa: F401
    except ImportError:
        assert isinstance(t, dict) and t["load_ohm"].tolist() == [1.0, 2.0]
    else:
        assert t.attrs["units"] == {"load_ohm": "ohm", "peak_current_A": "A (peak)"}
        assert list(t.columns) == ["load_ohm", "peak_current_A"]
