"""The published numbers the reproduce report compares against, in one place.

Every value here is read off a publication (paper = Bowen, Viñolas & Olazagoitia 2019;
EMPS = Janot et al. 2019) or, for the dissipation bound, fixed by the problem statement;
report sections import them from here and never restate them in their text.
"""

from __future__ import annotations

from ..datasets.emps import EMPS_REFERENCE

__all__ = ["EMPS_PUBLISHED", "EMPS_REFERENCE", "EXPECTED_DISSIPATION_BOUND_W",
           "PAPER_FIG14_RANGES", "PAPER_FIG21", "PAPER_OPTIMUM", "PAPER_ROAD_STUDY",
           "PAPER_TABLE4"]

#: Paper §4.2 optimum and changes (text of §4.2 and Fig 19): design variables, comfort and
#: road-holding improvements (%), power (W) and efficiency (%) prototype → optimum.
PAPER_OPTIMUM = {"total_inertia_gcm2": 250.0, "lead_mm_per_rev": 7.0,
                 "speed_constant_rpm_per_V": 29.8, "load_ohm": 75.0,
                 "comfort_improvement_pct": 23.86, "road_holding_improvement_pct": 26.91,
                 "power_W": (100.0, 162.0), "efficiency_pct": (36.0, 81.0)}

#: Paper Table 4 (100 km/h): no / min / max friction.
PAPER_TABLE4 = {"power_W": (174.9, 148.61, 110.1), "efficiency_pct": (81.0, 67.58, 49.64),
                "comfort_change_pct": (None, 0.57, -15.01),
                "road_holding_change_pct": (None, 1.7, 7.83)}

#: Paper Fig 21 / Table 4 per friction case: mean power (W), efficiency (%), peak power (W;
#: None where the paper gives none).
PAPER_FIG21 = {"none": (174.9, 81.0, None), "min": (148.61, 67.58, 710.0),
               "max": (110.1, 49.64, 580.0)}

#: Paper Fig 14: equivalent damping ranges (min–max friction, N s/m) of the open and the
#: short circuit.
PAPER_FIG14_RANGES = {"open circuit": (293.0, 2306.0), "short circuit": (2862.0, 6208.0)}

#: Paper Figs 15/16 text: the power lost to friction at equal damping slopes (%, range) and
#: the average sprung acceleration in all three friction cases (m/s²).
PAPER_ROAD_STUDY = {"power_loss_pct": (70.0, 80.0), "acceleration_m_s2": 3.0}

#: Published EMPS figures (Janot et al. 2019): relative force error (%) before/after the
#: direction-dependent friction, and its viscous (N s/m) and Coulomb (N) levels per direction.
EMPS_PUBLISHED = {"before": 4.08, "after": 3.11, "f_v_pos": 166.7, "f_v_neg": 240.4,
                  "F_C_pos": 20.14, "F_C_neg": 20.63}

#: The road's dissipation bound π² k1 G_d(n0) n0² V the passenger car on a class C road at
#: 100 km/h must give (W), the check of the road model.
EXPECTED_DISSIPATION_BOUND_W = 140.0
