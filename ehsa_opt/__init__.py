"""ehsa_opt — identify, simulate and optimally design ball-screw energy-harvesting
shock absorbers (Bowen, Viñolas & Olazagoitia 2019, and beyond)."""

from .bench import BenchSimulation, simulate_bench
from .friction import bearing_friction_Nm, nut_friction_N, rod_friction_N, simscape_friction
from .models import BenchModel
from .motion import SampledMotion, SineMotion
from .params import (FRICTION_NAMES, FRICTION_RANGES, FrictionParams, HarvesterParams,
                     ParameterError, RoadParams, VehicleParams)

__version__ = "0.1.0"

__all__ = ["BenchModel", "BenchSimulation", "simulate_bench", "SineMotion", "SampledMotion",
           "HarvesterParams", "FrictionParams", "VehicleParams", "RoadParams", "ParameterError",
           "FRICTION_NAMES", "FRICTION_RANGES", "simscape_friction", "nut_friction_N",
           "bearing_friction_Nm", "rod_friction_N", "__version__"]
