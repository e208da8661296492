"""A second bench-data generator, written from physics and independent of the product.

It shares no code with ``ehsa_opt`` (it does not import it at all): its own equations
(:mod:`.model`: LuGre friction with a Stribeck exponent, Hunt-Crossley contact in an
axial play, two-mass mount compliance, non-sinusoidal detents, Shockley diodes, a copper
energy balance, flux saturation, second-order sensor dynamics on the force and voltage
channels, a thermal drift of the friction over the campaign, and effects outside the
product's catalogue), its own
motions (:mod:`.motions`: sines, constant-velocity strokes, trapezoids, multisines,
road-like records) and its own writer of the bench directory format (:mod:`.campaign`).

    python -m validation.second_generator OUT_DIR --rig rig_b --protocol mixed --seed 1
"""

from .campaign import (PROTOCOL_SETS, RIGS, Campaign, Noise, Rig, generate, run_order,
                       test_specs, write_campaign)
from .model import Effects, Harvester, LuGre, RigModel
from .motions import Sine, multisine, road_like, trapezoid, triangle

__all__ = ["Campaign", "Noise", "Rig", "RIGS", "PROTOCOL_SETS", "generate", "test_specs",
           "write_campaign", "run_order", "Effects", "Harvester", "LuGre", "RigModel", "Sine", "multisine",
           "road_like", "trapezoid", "triangle"]
