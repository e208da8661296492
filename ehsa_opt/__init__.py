"""ehsa_opt — identify, simulate and optimally design ball-screw energy-harvesting
shock absorbers (Bowen, Viñolas & Olazagoitia 2019, and beyond)."""

from .physics import BenchModel
from .physics.bench_sim import BenchSimulation, simulate_bench
from .physics.friction import (
                     bearing_friction_Nm,
                     nut_friction_N,
                     rod_friction_N,
                     simscape_friction,
)
from .physics.motion import SampledMotion, SineMotion
from .physics.params import (
                     FRICTION_NAMES,
                     FRICTION_RANGES,
                     FrictionParams,
                     HarvesterParams,
                     ParameterError,
                     RoadParams,
                     VehicleParams,
)
from .utils.version import __version__

__all__ = ["BenchModel", "BenchSimulation", "simulate_bench", "SineMotion", "SampledMotion",
           "HarvesterParams", "FrictionParams", "VehicleParams", "RoadParams", "ParameterError",
           "FRICTION_NAMES", "FRICTION_RANGES", "simscape_friction", "nut_friction_N",
           "bearing_friction_Nm", "rod_friction_N", "__version__"]
