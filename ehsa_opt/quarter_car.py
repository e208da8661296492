"""Time-domain simulation of the quarter car with harvester and friction (SPEC §4–5).

Fast path: the step of :class:`~ehsa_opt.models.quarter_car.QuarterCarModel`
(trapezoidal mechanics + exact exponential electrical update + bracketed Newton
on the friction; see that module) is compiled to C by CasADi (``jit``, gcc),
rolled over time with ``mapaccum`` and over the designs of a batch with
``map``: one call simulates every design, no Python per step.  Without a C
compiler the same CasADi graph runs in CasADi's virtual machine (slower).

Why this scheme: L/R is 15–260 µs, the road band reaches a few hundred Hz and
the friction law is stiff near zero velocity (the Coulomb tanh has slope
F_C/(u_brk/10), up to ~10⁵ N s/m).  The electrical state is linear, so its
exponential update is exact for any step (no stiffness left); the mechanical
part is A-stable trapezoidal (second order: 0.1 % phase error per cycle of the
11 Hz wheel hop at 1 kHz); the only nonlinearity, the friction, enters one
scalar monotone equation per step, solved implicitly.

Metrics are computed after ``settle_s``.  For a synthesised road (periodic by
construction) the settle time is a pre-roll taken from the end of the road, so
the metrics cover exactly one road period — the linear steady state is then
sampled exactly and the frictionless results match the frequency path.
"""

from __future__ import annotations

import functools
import math
import tempfile
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import casadi as ca
import numpy as np

from .iso2631 import weighted_rms_fft
from .metrics import G, dimensionless_power
from .models.quarter_car import (PARAM_NAMES, STATE_NAMES, STEP_OUTPUT_NAMES, QuarterCarModel,
                                 param_vector)
from .params import FrictionParams, HarvesterParams, ParameterError, RoadParams, VehicleParams
from .road import RoadProfile, dissipation_bound_W, road_profile

__all__ = ["RoadHoldingWarning", "QuarterCarSimulation", "simulate_quarter_car",
           "simulate_batch", "compiled_step"]


class RoadHoldingWarning(UserWarning):
    """Road holding above 1: the tyre would leave the ground (linear tyre invalid)."""


_JIT_DIR: str | None = None


def _jit_directory() -> str:
    """A private temporary folder for CasADi's generated C and shared objects, so runs
    never litter the user's working directory."""
    global _JIT_DIR
    if _JIT_DIR is None:
        _JIT_DIR = tempfile.mkdtemp(prefix="ehsa_opt_jit_")
    return _JIT_DIR


@functools.lru_cache(maxsize=8)
def compiled_step(h: float, jit: bool = True) -> tuple[ca.Function, bool]:
    """The quarter-car step for step ``h`` (s), compiled when a C compiler works.

    Returns
    -------
    (casadi.Function, bool)
        The step function and whether it is compiled.
    """
    model = QuarterCarModel()
    if jit:
        try:
            opts = {"jit": True, "compiler": "shell",
                    "jit_options": {"flags": ["-O2"], "verbose": False,
                                    "directory": _jit_directory()}}
            return model.step_function(h, opts), True
        except Exception:  # noqa: BLE001 - no compiler: the VM evaluates the same graph
            pass
    return model.step_function(h), False


def _rolled(step: ca.Function, n: int) -> ca.Function:
    """``step`` rolled over ``n`` steps with the parameter column held fixed."""
    roll = step.mapaccum("roll", n, [0], [0])
    z = ca.MX.sym("z", step.size_in(0))
    xa, xb = ca.MX.sym("x0_k", 1, n), ca.MX.sym("x0_k1", 1, n)
    p = ca.MX.sym("p", step.size_in(3))
    zt, y = roll(z, xa, xb, ca.repmat(p, 1, n))
    return ca.Function("rolled", [z, xa, xb, p], [zt, y])


def simulate_batch(params: np.ndarray, x0: np.ndarray, h: float, jit: bool = True,
                   z0: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, bool]:
    """Simulate a batch of parameter vectors on one road signal.

    Parameters
    ----------
    params : ndarray (n_params, B)
        Columns from :func:`~ehsa_opt.models.quarter_car.param_vector`.
    x0 : ndarray (N + 1,)
        Road elevation at the sample times, m.
    h : float
        Time step, s.
    z0 : ndarray (5, B), optional
        Initial states (default rest).

    Returns
    -------
    states : ndarray (B, 5, N)
        States after each step.
    outputs : ndarray (B, len(STEP_OUTPUT_NAMES), N)
        Step outputs.
    compiled : bool
    """
    params = np.asarray(params, dtype=float)
    b = params.shape[1]
    n = x0.size - 1
    step, compiled = compiled_step(float(h), jit)
    batch = _rolled(step, n).map(b, "serial")
    z0 = np.zeros((len(STATE_NAMES), b)) if z0 is None else z0
    zt, y = batch(z0, x0[None, :-1], x0[None, 1:], params)
    zt = np.asarray(zt).reshape(len(STATE_NAMES), b, n).transpose(1, 0, 2)
    y = np.asarray(y).reshape(len(STEP_OUTPUT_NAMES), b, n).transpose(1, 0, 2)
    return zt, y, compiled


@dataclass
class QuarterCarSimulation:
    """Result of :func:`simulate_quarter_car` (mirrors ``OptimizeResult``).

    Attributes
    ----------
    success : bool
        All outputs finite.
    message : str
    metrics : dict of ndarray (B,)
        The keys of :data:`~ehsa_opt.metrics.METRIC_KEYS` plus ``energy_residual``
        (relative closure of the energy balance) and ``peak_power_W``.
    time_s : ndarray (N,)
        Times of the kept samples (0 = start of the metric window).
    road_m : ndarray (N,)
    series : dict of ndarray (B, N)
        Step outputs (:data:`STEP_OUTPUT_NAMES`) and states (``x2_m`` …), only
        the metric window; empty when ``keep_series=False``.
    harvesters, frictions : list
        The designs of the batch.
    stats : dict
        ``wall_s``, ``steps``, ``designs``, ``compiled``, ``sample_rate_hz``.
    """

    success: bool
    message: str
    metrics: dict[str, np.ndarray]
    time_s: np.ndarray
    road_m: np.ndarray
    series: dict[str, np.ndarray]
    vehicle: VehicleParams
    harvesters: list[HarvesterParams]
    frictions: list[FrictionParams]
    road_source: str
    stats: dict[str, Any] = field(default_factory=dict)

    def metrics_of(self, k: int = 0) -> dict[str, float | None]:
        """Metrics of design ``k`` as plain floats (None for a missing bound)."""
        out: dict[str, float | None] = {}
        for key, arr in self.metrics.items():
            val = float(arr[k])
            out[key] = None if math.isnan(val) else val
        return out

    def plot(self, k: int = 0) -> Any:
        """Road, sprung displacement, power and force–velocity of design ``k``."""
        from .plots.quarter_car import simulation_overview
        return simulation_overview(self, k)


def _as_list(obj: Any, cls: type, n: int | None) -> list:
    if obj is None:
        return [cls()] * (n or 1)
    if isinstance(obj, cls):
        return [obj] * (n or 1)
    items = list(obj)
    if not all(isinstance(o, cls) for o in items):
        raise TypeError(f"expected {cls.__name__} or a sequence of them")
    return items


_CHUNK_DESIGNS = 16


def _window_metrics(zt: np.ndarray, y: np.ndarray, params: np.ndarray, x0_keep: np.ndarray,
                    h: float, sample_rate_hz: float, vehicle: VehicleParams, speed: float,
                    bound: float | None) -> dict[str, np.ndarray]:
    """Metrics and energy-balance residual of a batch over the metric window."""
    n_b = zt.shape[0]
    # Energy balance over the window: road work = Δ stored + R i² + friction.
    stored = np.array([QuarterCarModel.stored_energy(zt[b], x0_keep, params[:, b])
                       for b in range(n_b)])
    col = {name: i for i, name in enumerate(STEP_OUTPUT_NAMES)}
    R = params[PARAM_NAMES.index("total_resistance_ohm")]
    cur = zt[:, STATE_NAMES.index("current_A"), :]

    def integral(sig: np.ndarray) -> np.ndarray:  # trapezoid over the window
        return h * (np.sum(sig, axis=1) - 0.5 * (sig[:, 0] + sig[:, -1]))

    work = np.sum(y[:, col["road_work_J"], 1:], axis=1)
    e_r = integral(R[:, None] * cur ** 2)
    e_f = integral(y[:, col["friction_power_W"], :])
    d_stored = stored[:, -1] - stored[:, 0]
    scale = np.maximum(np.abs(work), 1e-300)
    residual = (work - d_stored - e_r - e_f) / scale
    acc = y[:, col["sprung_acc_m_s2"], :]
    acc_w = np.array([weighted_rms_fft(a, sample_rate_hz) for a in acc])
    k1 = vehicle.tyre_stiffness_N_per_m
    tyre = y[:, col["tyre_deflection_m"], :]
    power = y[:, col["load_power_W"], :]
    p_mean = power.mean(axis=1)
    p_diss = y[:, col["damper_power_W"], :].mean(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        eff = np.where(p_diss > 0.0, p_mean / p_diss, 0.0)
    return {
        "comfort": acc_w / G,
        "comfort_weighted_rms_m_s2": acc_w,
        "road_holding": k1 * np.sqrt(np.mean(tyre ** 2, axis=1)) / (G * vehicle.total_mass_kg),
        "power_W": p_mean,
        "power_dimensionless": dimensionless_power(p_mean, vehicle, speed),
        "efficiency": eff,
        "dissipated_power_W": p_diss,
        "dissipation_bound_W": np.full(n_b, np.nan if bound is None else bound),
        "peak_power_W": power.max(axis=1),
        "energy_residual": residual,
    }


def simulate_quarter_car(vehicle: VehicleParams,
                         harvester: HarvesterParams | Sequence[HarvesterParams] | None = None,
                         friction: FrictionParams | Sequence[FrictionParams] | None = None,
                         road: RoadParams | RoadProfile | None = None, *,
                         settle_s: float = 2.0, sample_rate_hz: float = 1000.0,
                         base_dir: str | Path | None = None, keep_series: bool = True,
                         jit: bool = True, warn: bool = True) -> QuarterCarSimulation:
    """Simulate one or many harvester/friction designs on one road (time domain).

    Parameters
    ----------
    vehicle : VehicleParams
    harvester, friction : params or sequences of them
        Broadcast together (a single one is repeated); ``friction=None`` is
        frictionless.
    road : RoadParams or RoadProfile
        ISO 8608 class (synthesised, seeded) or a measured profile.
    settle_s : float
        Start excluded from the metrics, s (a pre-roll for synthesised roads).
    sample_rate_hz : float
        Time step 1/fs.
    base_dir : path, optional
        Folder that a relative ``profile_csv`` is relative to.
    keep_series : bool
        Keep the time series (memory: 14 × B × N doubles).
    jit : bool
        Compile the step with CasADi's C code generation when possible.
    warn : bool
        Emit :class:`RoadHoldingWarning` when η_rh > 1.

    Returns
    -------
    QuarterCarSimulation
    """
    if settle_s < 0.0 or not math.isfinite(settle_s):
        raise ParameterError(f"simulation: settle_s = {settle_s} must be >= 0 s")
    if not (sample_rate_hz > 0.0 and math.isfinite(sample_rate_hz)):
        raise ParameterError(f"simulation: sample_rate_hz = {sample_rate_hz} must be > 0 Hz")
    road = road or RoadParams()
    if isinstance(road, RoadParams):
        road_params: RoadParams | None = road
        profile = road_profile(road, sample_rate_hz, base_dir)
    else:
        road_params, profile = None, road
    if abs(profile.sample_rate_hz - sample_rate_hz) > 1e-9 * sample_rate_hz:
        raise ParameterError("simulation: the road profile's sample rate differs from "
                             "sample_rate_hz; build the profile at the simulation rate")
    n_h = None
    if not isinstance(harvester, HarvesterParams) and harvester is not None:
        n_h = len(list(harvester))
    n_f = None
    if not isinstance(friction, FrictionParams) and friction is not None:
        n_f = len(list(friction))
    n = max(n_h or 1, n_f or 1)
    hs = _as_list(harvester, HarvesterParams, n)
    fs_ = _as_list(friction, FrictionParams, n)
    if len(hs) != len(fs_):
        raise ValueError(f"{len(hs)} harvesters but {len(fs_)} friction sets: give one or equal "
                         "numbers")
    h = 1.0 / sample_rate_hz
    x_road = profile.elevation_m
    n_settle = int(round(settle_s * sample_rate_hz))
    periodic = profile.band_cycles_per_m is not None
    if periodic:
        pre = x_road[-n_settle:] if n_settle else x_road[:0]
        x_in = np.concatenate([pre, x_road, x_road[:1]])
        keep = slice(n_settle, n_settle + x_road.size)
    else:
        if n_settle >= x_road.size - 16:
            raise ParameterError(f"simulation: settle_s = {settle_s} s leaves no data on a "
                                 f"{x_road.size / sample_rate_hz:.3g} s road; shorten settle_s "
                                 "or lengthen the road")
        x_in = np.concatenate([x_road[:1], x_road])  # start at rest on the first sample
        keep = slice(n_settle, x_road.size)
    # Start at rest with the car on the road's first elevation.
    params = np.stack([param_vector(vehicle, hh, ff) for hh, ff in zip(hs, fs_)], axis=1)
    z0 = np.zeros((len(STATE_NAMES), len(hs)))
    z0[0, :] = z0[1, :] = x_in[0]
    x0_keep = x_in[1:][keep]
    bound = dissipation_bound_W(vehicle, road_params) if road_params is not None else None
    # Without series, simulate in chunks of designs so memory stays bounded
    # (14 doubles per design and step are produced by the compiled roll).
    chunk = len(hs) if keep_series else _CHUNK_DESIGNS
    parts, wall, compiled = [], 0.0, False
    zt = y = None
    for lo in range(0, len(hs), chunk):
        sl = slice(lo, min(lo + chunk, len(hs)))
        t0 = time.perf_counter()
        zt, y, compiled = simulate_batch(params[:, sl], x_in, h, jit, z0[:, sl])
        wall += time.perf_counter() - t0
        zt, y = zt[:, :, keep], y[:, :, keep]
        parts.append(_window_metrics(zt, y, params[:, sl], x0_keep, h, sample_rate_hz,
                                     vehicle, profile.speed_m_per_s, bound))
    metrics = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    finite = all(np.all(np.isfinite(a)) for k, a in metrics.items() if k != "dissipation_bound_W")
    msg = "ok" if finite else "non-finite results: the step diverged (check parameters)"
    if warn:
        for b in np.flatnonzero(metrics["road_holding"] > 1.0):
            warnings.warn(f"design {b}: road holding {metrics['road_holding'][b]:.2f} > 1: the "
                          "tyre would leave the ground; the linear tyre model is invalid there",
                          RoadHoldingWarning, stacklevel=2)
    series: dict[str, np.ndarray] = {}
    if keep_series:
        series = {name: y[:, i, :] for i, name in enumerate(STEP_OUTPUT_NAMES)}
        series.update({name: zt[:, i, :] for i, name in enumerate(STATE_NAMES)})
    n_keep = x0_keep.size
    return QuarterCarSimulation(
        success=finite, message=msg, metrics=metrics, time_s=np.arange(n_keep) * h + h,
        road_m=x0_keep, series=series, vehicle=vehicle, harvesters=hs, frictions=fs_,
        road_source=profile.source,
        stats={"wall_s": wall, "steps": int(x_in.size - 1), "designs": len(hs),
               "compiled": compiled, "sample_rate_hz": float(sample_rate_hz)})
