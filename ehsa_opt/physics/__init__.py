"""Symbolic models: the harvester's equivalent quantities, the bench model and its
pluggable components."""

from .base_parameters import PARAMETERS, Parameter
from .bench_model import BenchModel
from .components import (
                         COMPONENTS,
                         AsymmetricFriction,
                         Backlash,
                         Cogging,
                         Compliance,
                         Component,
                         Flexibility,
                         MagneticSaturation,
                         ParamSpec,
                         PositionFriction,
                         VoltageDrop,
                         WindingHeating,
                         make_component,
)
from .harvester import (
                         equivalent_damping_Ns_per_m,
                         equivalent_impedance,
                         equivalent_mass_kg,
                         equivalent_stiffness_N_per_m,
)

__all__ = ["Parameter", "PARAMETERS", "BenchModel", "Component", "ParamSpec", "Backlash", "Compliance", "AsymmetricFriction",
           "Cogging", "VoltageDrop", "WindingHeating", "PositionFriction", "MagneticSaturation",
           "Flexibility", "COMPONENTS",
           "make_component", "equivalent_mass_kg", "equivalent_damping_Ns_per_m",
           "equivalent_stiffness_N_per_m", "equivalent_impedance"]
