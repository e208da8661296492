"""The design problem every design step of the reproduce report starts from: the
paper's problem file, with ``reproduce --vehicle`` / ``--data`` applied, and the
design steps' cache key."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .base import Context, StepOutput

if TYPE_CHECKING:
    from ..design.config import DesignConfig

__all__ = ["PAPER_DESIGN_FILE", "design_config", "design_inputs", "not_applicable"]

#: The problem file of paper §4.2 (shipped in the package; ``problems/`` at the top of the
#: repository links to it).
PAPER_DESIGN_FILE = Path(__file__).resolve().parent.parent / "problems" / "paper_design.toml"


def design_inputs(ctx: Context) -> Any:
    """Cache key of the design steps: the problem file's text and the data/vehicle."""
    text = PAPER_DESIGN_FILE.read_text() if PAPER_DESIGN_FILE.is_file() else None
    return [text, ctx.inputs()] if (ctx.custom_data or ctx.vehicle_file) else text


def design_config(ctx: Context | None = None, motor_model: str = "paper") -> DesignConfig:
    """The paper's design problem; with ``reproduce --vehicle`` its vehicle replaced, with
    ``reproduce --data`` the user's harvester (bench.toml: winding, inductance, inertia,
    constants) as the start of the design space.  ``motor_model``: "paper" (R_i, L_i
    fixed: the paper's design space, used by the reproduction steps) or "scaling" (the
    product's default: the user's frame rewound, with rated limits)."""
    from ..design.config import load_design_config
    if not PAPER_DESIGN_FILE.is_file():
        raise FileNotFoundError(f"{PAPER_DESIGN_FILE} not found (the package is incomplete: "
                                f"reinstall it)")
    cfg = load_design_config(PAPER_DESIGN_FILE)
    if ctx is not None and ctx.vehicle_file is not None:
        vehicle, name = ctx.vehicle()
        cfg = dataclasses.replace(cfg, vehicle=vehicle, vehicle_name=name)
    if ctx is not None and ctx.custom_data and ctx.has_generator:
        cfg = dataclasses.replace(cfg, harvester=ctx.harvester(load_ohm=cfg.harvester.load_ohm))
    return dataclasses.replace(cfg, motor_model=motor_model)


def not_applicable(ctx: Context) -> StepOutput | None:
    """The design steps' section on a rig without generator (None when they apply)."""
    if ctx.has_generator:
        return None
    return StepOutput("Not applicable: the bench rig has no generator, so the design of a "
                      "harvester (inertia, lead, generator constant, load) has nothing to "
                      "start from in these data.\n", [], {"applicable": False})
