"""Bench simulation: integrate a :class:`~ehsa_opt.physics.bench_model.BenchModel` under a
prescribed motion, with the energy bookkeeping integrated alongside.

The electrical state is stiff (L/R = 15–260 µs) and backlash contacts are stiff
too, so the integrator is CasADi's CVODES (variable-order BDF) with tight
tolerances; the energy terms are integrated as quadratures, exactly on the same
steps.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import casadi as ca
import numpy as np

from .bench_model import BenchModel
from .motion import SampledMotion, SineMotion

__all__ = ["BenchSimulation", "simulate_bench", "max_step_s"]


@dataclass
class BenchSimulation:
    """Result of :func:`simulate_bench`.

    Attributes
    ----------
    time_s : ndarray (N,)
    displacement_m, velocity_m_per_s, acceleration_m_per_s2 : ndarray (N,)
        The prescribed rod motion.
    force_N, voltage_V : ndarray (N,)
        Simulated load-cell force and generator (load) voltage.
    states : ndarray (n_states, N)
        Model states, named by ``state_names``.
    energy_J : dict[str, ndarray]
        Empty when simulated without them (``simulate_bench(..., energy=False)``).
        Cumulative energies from t0: ``work_in``, ``load``, ``winding``, ``friction``,
        ``component``, and ``stored`` (stored kinetic + magnetic + elastic energy,
        absolute).
    """

    time_s: np.ndarray
    displacement_m: np.ndarray
    velocity_m_per_s: np.ndarray
    acceleration_m_per_s2: np.ndarray
    force_N: np.ndarray
    voltage_V: np.ndarray
    states: np.ndarray
    state_names: list[str]
    energy_J: dict[str, np.ndarray]

    def energy_residual(self) -> float:
        """Relative closure error of the energy balance over the whole run.

        (W_in − (E_load + E_winding + E_friction + E_component + ΔE_stored)) / W_abs,
        with W_abs = ∫|F v| dt.
        """
        e = self.energy_J
        out = e["load"][-1] + e["winding"][-1] + e["friction"][-1] + e["component"][-1] \
            + (e["stored"][-1] - e["stored"][0])
        return float((e["work_in"][-1] - out) / e["work_in_abs"][-1])


def max_step_s(motion: Any, grid: np.ndarray) -> float:
    """Largest CVODES step on a prescribed non-sine motion, s: the motion's own
    ``max_step_s`` (half its shortest segment, its sample step, …) when it has one, and
    never more than the output grid's median step."""
    g = float(np.median(np.diff(grid)))
    own = getattr(motion, "max_step_s", None)
    return float(min(g, own)) if own is not None and own > 0 else g


def _integrator(model: BenchModel, motion: Any, grid: np.ndarray, rtol: float,
                atol: float, energy: bool = True) -> ca.Function:
    """Build (and for sine motions cache on the model) the CVODES integrator; ``energy``
    False: without the energy quadratures (:func:`simulate_bench`).

    The cache lives on the model object, so it dies with the model (a module-level
    cache keyed by ``id(model)`` could hand a stale integrator to a new model that
    reuses a freed id).
    """
    sine = isinstance(motion, SineMotion)
    cache: dict = model.__dict__.setdefault("_integrator_cache", {})
    key = (len(grid), float(grid[0]), float(grid[-1]), rtol, atol, energy) if sine else None
    if key is not None and key in cache:
        return cache[key]
    t = ca.MX.sym("t")
    p = ca.MX.sym("p", len(model.param_names))
    if sine:
        mp = ca.MX.sym("motion", 3)  # A, f, phase
        w = 2 * np.pi * mp[1]
        ph = w * t + mp[2]
        u = ca.vertcat(mp[0] * ca.sin(ph), mp[0] * w * ca.cos(ph), -mp[0] * w * w * ca.sin(ph))
        pall = ca.vertcat(p, mp)
    else:
        u = ca.vertcat(*motion.expressions(t))
        pall = p
    nx = model.n_states
    x = ca.MX.sym("x", nx)
    xdot = model.ode(x, u, p) if nx else ca.MX(0, 1)
    e = model.energy(x, u, p)
    quad = ca.vertcat(e[0], e[1], e[2], e[3], e[4], ca.fabs(e[0]))
    if nx == 0:  # quadrature-only problem: add a dummy state
        x = ca.MX.sym("dummy")
        xdot = ca.MX(0)
    dae = {"x": x, "t": t, "p": pall, "ode": xdot, **({"quad": quad} if energy else {})}
    opts = {"abstol": atol, "reltol": rtol, "max_num_steps": 500000}
    if not sine:
        # a step may not jump over a feature of the motion: on a constant-velocity stroke
        # the states sit at equilibrium, CVODES grows its step, and without this cap it
        # steps over a 20 ms reversal as if it had not happened
        opts["max_step_size"] = max_step_s(motion, grid)
    F = ca.integrator("bench_sim", "cvodes", dae, float(grid[0]), grid[1:].tolist(), opts)
    if key is not None:
        cache[key] = F
    return F


def simulate_bench(model: BenchModel, motion: SineMotion | SampledMotion, p: Any,
                   time_s: np.ndarray, *, rtol: float = 1e-9, atol: float = 1e-11,
                   x0: np.ndarray | None = None, energy: bool = True) -> BenchSimulation:
    """Simulate the bench with prescribed rod motion.

    Parameters
    ----------
    model : BenchModel
    motion : SineMotion or SampledMotion
    p : array-like
        Parameter vector in ``model.param_names`` order (see
        :meth:`BenchModel.param_vector`).
    time_s : ndarray
        Output grid (s), strictly increasing; the simulation starts at ``time_s[0]``.
    rtol, atol : float
        CVODES tolerances.
    x0 : ndarray, optional
        Initial state; default :meth:`BenchModel.initial_state`.
    energy : bool
        Integrate the energy bookkeeping (default).  False: the states and outputs only
        (``energy_J`` empty) — the same numbers, bit for bit (the quadratures are not in
        CVODES' error test, so they do not change its steps), about 30 % cheaper on a
        stiff contact (the fits' simulations, which read the force and voltage alone).

    Returns
    -------
    BenchSimulation
    """
    grid = np.asarray(time_s, dtype=float)
    if grid.ndim != 1 or grid.size < 2 or np.any(np.diff(grid) <= 0):
        raise ValueError("simulate_bench: time_s must be 1-D, strictly increasing, >= 2 samples")
    p = np.asarray(p, dtype=float).ravel()
    if p.size != len(model.param_names):
        raise ValueError(f"simulate_bench: p has {p.size} entries, the model needs "
                         f"{len(model.param_names)} ({', '.join(model.param_names)})")
    uu = motion.evaluate(grid)
    if x0 is None:
        x0 = model.initial_state(uu[:, 0], p)
    F = _integrator(model, motion, grid, rtol, atol, energy)
    pall = np.concatenate([p, [motion.amplitude_m, motion.frequency_hz, motion.phase_rad]]) \
        if isinstance(motion, SineMotion) else p
    x0v = x0 if model.n_states else np.zeros(1)
    res = F(x0=x0v, p=pall)
    xs = np.hstack([np.reshape(x0v, (-1, 1)), np.array(res["xf"])])
    if not model.n_states:
        xs = np.zeros((0, grid.size))
    y = np.array(model.outputs.map(grid.size)(xs, uu, p)) if model.n_states else \
        np.array(model.outputs.map(grid.size)(np.zeros((0, grid.size)), uu, p))
    if not energy:
        return BenchSimulation(grid, uu[0], uu[1], uu[2], y[0], y[1], xs,
                               list(model.state_names), {})
    qf = np.hstack([np.zeros((6, 1)), np.array(res["qf"])])
    stored = np.array(model.energy.map(grid.size)(xs, uu, p))[5]
    energies = {"work_in": qf[0], "load": qf[1], "winding": qf[2], "friction": qf[3],
                "component": qf[4], "work_in_abs": qf[5], "stored": stored}
    return BenchSimulation(grid, uu[0], uu[1], uu[2], y[0], y[1], xs, list(model.state_names),
                           energies)
