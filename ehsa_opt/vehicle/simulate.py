"""Time-domain simulation of the quarter car with harvester and friction (paper §4, Eqs 6–9).

Fast path: the step of :class:`~ehsa_opt.physics.quarter_car_model.QuarterCarModel`
(trapezoidal mechanics + exact exponential electrical update + bracketed Newton
on the friction; see that module) is compiled to C by CasADi (``jit``, gcc),
mapped over a chunk of designs (``map``) and rolled over a block of 256 steps
(``mapaccum``).  That graph depends only on (step, chunk size), so it is built
once and cached; a road of any length is a sequence of calls of it (padded to
whole blocks), written straight into numpy arrays through CasADi's buffer
interface, no Python per step and no DM conversion.  Chunks of designs bound the
memory and are shared by two threads (the buffered call releases the GIL).
Without a C compiler the same CasADi graph runs in CasADi's virtual machine
(slower).

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
import os
import threading
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import casadi as ca
import numpy as np

from ..physics.params import (
    FrictionParams,
    HarvesterParams,
    ParameterError,
    RoadParams,
    VehicleParams,
)
from ..physics.quarter_car_model import (
    PARAM_NAMES,
    STATE_NAMES,
    STEP_OUTPUT_NAMES,
    QuarterCarModel,
    param_vector,
)
from ..utils.jit_cache import compiled
from .frequency_path import G, dimensionless_power
from .iso2631 import weighted_rms_fft
from .resources import check_simulation_resources
from .road import RoadProfile, dissipation_bound_W, road_profile
from .validity import SampleLimits, exceedance_fractions

__all__ = ["RoadHoldingWarning", "FrictionRangeWarning", "QuarterCarSimulation", "simulate_quarter_car",
           "simulate_batch", "compiled_step", "batch_graph_cache_info"]


class FrictionRangeWarning(UserWarning):
    """More than the limit of the time or of the friction's dissipated energy lies above
    the friction's identified range (:mod:`ehsa_opt.vehicle.coverage`)."""


class RoadHoldingWarning(UserWarning):
    """Road holding above 1: the tyre would leave the ground (linear tyre invalid)."""


@functools.lru_cache(maxsize=8)
def compiled_step(h: float, jit: bool = True, law: str = "static") -> tuple[ca.Function, bool]:
    """The quarter-car step for step ``h`` (s) under friction law ``law``, compiled when a
    C compiler works
    (:func:`ehsa_opt.utils.jit_cache.compiled`: once per generated code, then loaded from
    the per-user cache).

    Returns
    -------
    (casadi.Function, bool)
        The step function and whether it is compiled.
    """
    step = QuarterCarModel().step_function(h, law=law)
    fast = compiled(step) if jit else None  # from the per-user cache after the first run
    return (step, False) if fast is None else (fast, True)


#: Time steps per call of the cached block function (the graph does not depend on the
#: road length; a road is padded to a whole number of blocks).
_BLOCK_STEPS = 256
#: Memory per chunk of designs in flight (14 doubles per design and step).
_CHUNK_BYTES = 64 * 2 ** 20
_MAX_CHUNK_DESIGNS = 32
_N_OUT = len(STATE_NAMES) + len(STEP_OUTPUT_NAMES)
_CASADI_LOCK = threading.Lock()


@functools.lru_cache(maxsize=32)
def _block_function(h: float, jit: bool, n_designs: int,
                    n_steps: int = _BLOCK_STEPS, law: str = "static") -> ca.Function:
    """``n_steps`` steps of ``n_designs`` designs on one road signal, built once per
    structure and cached (:func:`batch_graph_cache_info` counts the builds).

    (z (5, B), x0_k (1, n), x0_k1 (1, n), p (n_params, B)) → (z_traj (5, B n),
    y (9, B n)); the columns are time-major (step k, design b at column k B + b), so
    consecutive blocks of a run are consecutive rows of a C-ordered (N, B, ·) array.
    """
    step, _ = compiled_step(h, jit, law)
    designs = step.map("designs", "serial", n_designs, [1, 2], [])
    roll = designs.mapaccum("roll", n_steps, [0], [0])
    z = ca.MX.sym("z", step.size1_in(0), n_designs)
    xa, xb = ca.MX.sym("x0_k", 1, n_steps), ca.MX.sym("x0_k1", 1, n_steps)
    p = ca.MX.sym("p", step.size1_in(3), n_designs)
    zt, y = roll(z, xa, xb, ca.repmat(p, 1, n_steps))
    return ca.Function("block", [z, xa, xb, p], [zt, y])


def batch_graph_cache_info() -> Any:
    """``functools`` cache statistics of the block graphs (``misses`` = builds)."""
    return _block_function.cache_info()


def _run_designs(params: np.ndarray, x_pad: np.ndarray, z0: np.ndarray, h: float,
                 jit: bool) -> tuple[np.ndarray, np.ndarray]:
    """Roll one chunk of designs over the padded road (``x_pad.size - 1`` a multiple of
    :data:`_BLOCK_STEPS`), block by block, straight into numpy arrays (CasADi's
    buffer interface: no DM objects).

    Returns
    -------
    Z : ndarray (N, B, 5)
        States after each step.
    Y : ndarray (N, B, 9)
        Step outputs.
    """
    b = params.shape[1]
    n = x_pad.size - 1
    nb = _BLOCK_STEPS
    lugre = params[PARAM_NAMES.index("friction_law_lugre")] > 0.5
    if lugre.any() and not lugre.all():  # one graph per friction law
        Z = np.empty((n, b, len(STATE_NAMES)))
        Y = np.empty((n, b, len(STEP_OUTPUT_NAMES)))
        for mask in (lugre, ~lugre):
            Z[:, mask], Y[:, mask] = _run_designs(params[:, mask], x_pad,
                                                  np.asarray(z0)[:, mask], h, jit)
        return Z, Y
    law = "lugre" if lugre.all() else "static"
    with _CASADI_LOCK:  # graph building, JIT and memory checkout: one thread at a time
        buf, evaluate = _block_function(float(h), bool(jit), b, nb, law).buffer()
    Z = np.empty((n, b, len(STATE_NAMES)))
    Y = np.empty((n, b, len(STEP_OUTPUT_NAMES)))
    p = np.asfortranarray(params, dtype=float).ravel(order="F")
    z = np.ascontiguousarray(np.asarray(z0, dtype=float).T)  # (B, 5) C = (5, B) Fortran
    x = np.ascontiguousarray(x_pad, dtype=float)
    buf.set_arg(3, memoryview(p))
    for k0 in range(0, n, nb):
        za, xa, xb = z.reshape(-1), x[k0:k0 + nb], x[k0 + 1:k0 + nb + 1]
        zo, yo = Z[k0:k0 + nb].reshape(-1), Y[k0:k0 + nb].reshape(-1)
        buf.set_arg(0, memoryview(za))
        buf.set_arg(1, memoryview(xa))
        buf.set_arg(2, memoryview(xb))
        buf.set_res(0, memoryview(zo))
        buf.set_res(1, memoryview(yo))
        evaluate()
        if buf.ret() != 0:
            raise RuntimeError(f"quarter-car block evaluation failed (CasADi status "
                               f"{buf.ret()})")
        z = Z[k0 + nb - 1]
    with _CASADI_LOCK:  # memory release, like the checkout
        del buf, evaluate
    return Z, Y


def _padded(x0: np.ndarray) -> np.ndarray:
    """Road samples padded with the last one to a whole number of blocks (the extra
    steps come after the real ones and are discarded)."""
    n = x0.size - 1
    n_pad = -(-n // _BLOCK_STEPS) * _BLOCK_STEPS
    return np.concatenate([x0, np.full(n_pad - n, x0[-1])])


def _chunks(n_designs: int, n_steps: int) -> list[slice]:
    """Balanced chunks of designs: each within :data:`_CHUNK_BYTES`, at least two
    when there are two designs (so two threads can share them); depends only on the
    batch's size, so results do not depend on ``threads`` or ``keep_series``."""
    per_design = _N_OUT * 8 * max(n_steps, 1)
    b_max = int(max(1, min(_MAX_CHUNK_DESIGNS, _CHUNK_BYTES // per_design)))
    n_chunks = max(-(-n_designs // b_max), min(2, n_designs))
    size = -(-n_designs // n_chunks)
    return [slice(lo, min(lo + size, n_designs)) for lo in range(0, n_designs, size)]


def _series_names(keep_series: bool | Sequence[str]) -> tuple[str, ...]:
    """Names of the series to keep: all, none or the given ones (checked)."""
    every = STEP_OUTPUT_NAMES + STATE_NAMES
    if isinstance(keep_series, (bool, np.bool_)):
        return every if keep_series else ()
    names = (keep_series,) if isinstance(keep_series, str) else tuple(keep_series)
    unknown = [n for n in names if n not in every]
    if unknown:
        raise ParameterError(f"simulation: keep_series names {unknown} are not series; valid: "
                             f"{', '.join(every)}")
    return names


def _default_threads() -> int:
    """Two threads on a machine with two or more CPUs, one inside a worker process
    (a process pool or Dask worker already uses the cores)."""
    import multiprocessing
    try:
        cpus = len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        cpus = os.cpu_count() or 1
    return 1 if multiprocessing.parent_process() is not None else min(2, cpus)


def simulate_batch(params: np.ndarray, x0: np.ndarray, h: float, jit: bool = True,
                   z0: np.ndarray | None = None, threads: int | None = None
                   ) -> tuple[np.ndarray, np.ndarray, bool]:
    """Simulate a batch of parameter vectors on one road signal.

    Parameters
    ----------
    params : ndarray (n_params, B)
        Columns from :func:`~ehsa_opt.physics.quarter_car_model.param_vector`.
    x0 : ndarray (N + 1,)
        Road elevation at the sample times, m.
    h : float
        Time step, s.
    z0 : ndarray (5, B), optional
        Initial states (default rest).
    threads : int, optional
        Threads sharing the chunks of designs (default: 2 on a multi-core machine,
        1 inside a worker process).

    Returns
    -------
    states : ndarray (B, 5, N)
        States after each step (a view of a time-major array).
    outputs : ndarray (B, len(STEP_OUTPUT_NAMES), N)
        Step outputs (likewise).
    compiled : bool
    """
    params = np.asarray(params, dtype=float)
    b = params.shape[1]
    x0 = np.asarray(x0, dtype=float)
    n = x0.size - 1
    _, compiled = compiled_step(float(h), jit)
    z0 = np.zeros((len(STATE_NAMES), b)) if z0 is None else np.asarray(z0, dtype=float)
    x_pad = _padded(x0)
    Z = np.empty((n, b, len(STATE_NAMES)))
    Y = np.empty((n, b, len(STEP_OUTPUT_NAMES)))

    def work(sl: slice) -> None:
        zc, yc = _run_designs(params[:, sl], x_pad, z0[:, sl], h, jit)
        Z[:, sl], Y[:, sl] = zc[:n], yc[:n]

    _map_threads(work, _chunks(b, x_pad.size - 1), threads)
    return Z.transpose(1, 2, 0), Y.transpose(1, 2, 0), compiled


def _map_threads(fn: Any, items: list, threads: int | None) -> list:
    """``[fn(i) for i in items]`` on a pool of threads (CasADi's buffered evaluation
    releases the GIL); in order."""
    threads = _default_threads() if threads is None else int(threads)
    if threads <= 1 or len(items) <= 1:
        return [fn(i) for i in items]
    from concurrent.futures import ThreadPoolExecutor
    with ThreadPoolExecutor(min(threads, len(items))) as pool:
        return list(pool.map(fn, items))


@dataclass
class QuarterCarSimulation:
    """Result of :func:`simulate_quarter_car` (mirrors ``OptimizeResult``).

    Attributes
    ----------
    success : bool
        All outputs finite.
    message : str
    metrics : dict of ndarray (B,)
        The keys of :data:`~ehsa_opt.vehicle.frequency_path.METRIC_KEYS` plus ``energy_residual``
        (relative closure of the energy balance), ``peak_power_W`` and the rms and peak
        of stroke, generator voltage and current (``stroke_rms_m``, ``peak_stroke_m``,
        ``voltage_rms_V``, ``peak_voltage_V``, ``current_rms_A``, ``peak_current_A``), the
        peak screw speed and the shares of the time beyond the per-sample limits
        (:func:`~ehsa_opt.vehicle.validity.exceedance_fractions`: ``tyre_lift_fraction``,
        ``stroke_beyond_limit_fraction``, ``*_beyond_limit_fraction``).
    time_s : ndarray (N,)
        Times of the kept samples (0 = start of the metric window).
    road_m : ndarray (N,)
    series : dict of ndarray (B, N)
        Step outputs (:data:`STEP_OUTPUT_NAMES`) and states (``x2_m`` …), only
        the metric window; only those asked for by ``keep_series`` (none by default).
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

    def plot(self, ax: Any = None, k: int = 0,
             identified_range_m_per_s: float | None = None) -> Any:
        """Road, sprung displacement, power and force–velocity of design ``k`` (four
        panels; ``ax`` not used; velocities beyond ``identified_range_m_per_s`` shaded);
        writes nothing."""
        missing = [n for n in ("x2_m", "load_power_W", "sprung_acc_m_s2",
                               "stroke_velocity_m_s", "damper_force_N") if n not in self.series]
        if missing:
            raise ValueError(f"plot needs the series {missing}: simulate with "
                             f"keep_series=True")
        from ..plots.quarter_car import simulation_overview
        return simulation_overview(self, k, identified_range_m_per_s)


def _as_list(obj: Any, cls: type, n: int | None) -> list:
    if obj is None:
        return [cls()] * (n or 1)
    if isinstance(obj, cls):
        return [obj] * (n or 1)
    items = list(obj)
    if not all(isinstance(o, cls) for o in items):
        raise TypeError(f"expected {cls.__name__} or a sequence of them")
    return items


def _window_metrics(zt: np.ndarray, y: np.ndarray, params: np.ndarray, x0_keep: np.ndarray,
                    h: float, sample_rate_hz: float, vehicle: VehicleParams, speed: float,
                    bound: float | None, v_range: float | None = None,
                    limits: SampleLimits | None = None) -> dict[str, np.ndarray]:
    """Metrics and energy-balance residual of a batch over the metric window (with
    ``v_range``: the fractions of time and friction energy above it; the shares of the
    time beyond the per-sample limits, :func:`~ehsa_opt.vehicle.validity.exceedance_fractions`)."""
    n_b = zt.shape[0]
    # Energy balance over the window: road work = Δ stored + R i² + friction.
    ends = [0, -1]
    stored = np.array([QuarterCarModel.stored_energy(zt[b][:, ends], x0_keep[ends],
                                                     params[:, b]) for b in range(n_b)])
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
    extra = {}
    if v_range is not None:
        from .coverage import series_coverage
        cov = series_coverage(y[:, col["stroke_velocity_m_s"], :], v_range,
                              np.maximum(y[:, col["friction_power_W"], :], 0.0))
        extra = {"out_of_range_time_fraction": cov["time_fraction"],
                 "out_of_range_friction_energy_fraction": cov["energy_fraction"]}
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
        **extra,
        **_rating_metrics(zt, y),
        **exceedance_fractions(
            zt[:, STATE_NAMES.index("x2_m"), :] - zt[:, STATE_NAMES.index("x1_m"), :], tyre,
            y[:, col["stroke_velocity_m_s"], :], y[:, col["voltage_V"], :],
            zt[:, STATE_NAMES.index("current_A"), :],
            static_deflection_m=G * vehicle.total_mass_kg / k1,
            stroke_limit_m=vehicle.stroke_limit_m,
            lead_m_per_rad=params[PARAM_NAMES.index("lead_m_per_rad")], limits=limits),
    }


def _rating_metrics(zt: np.ndarray, y: np.ndarray) -> dict[str, np.ndarray]:
    """rms and peak of the stroke x2 − x1, generator voltage and current over the window
    (what a motor's rated limits and the stroke limit are checked against)."""
    stroke = zt[:, STATE_NAMES.index("x2_m"), :] - zt[:, STATE_NAMES.index("x1_m"), :]
    volt = y[:, STEP_OUTPUT_NAMES.index("voltage_V"), :]
    cur = zt[:, STATE_NAMES.index("current_A"), :]
    out = {}
    for name, sig, unit in (("stroke", stroke, "m"), ("voltage", volt, "V"),
                            ("current", cur, "A")):
        out[f"{name}_rms_{unit}"] = np.sqrt(np.mean(sig * sig, axis=1))
        out[f"peak_{name}_{unit}"] = np.max(np.abs(sig), axis=1)
    return out


def simulate_quarter_car(vehicle: VehicleParams,
                         harvester: HarvesterParams | Sequence[HarvesterParams] | None = None,
                         friction: FrictionParams | Sequence[FrictionParams] | None = None,
                         road: RoadParams | RoadProfile | None = None, *,
                         settle_s: float = 2.0, sample_rate_hz: float = 1000.0,
                         base_dir: str | Path | None = None,
                         keep_series: bool | Sequence[str] = False,
                         jit: bool = True, warn: bool = True,
                         threads: int | None = None,
                         identified_range_m_per_s: float | None = None,
                         sample_limits: SampleLimits | None = None
                         ) -> QuarterCarSimulation:
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
    keep_series : bool or sequence of str
        Keep the time series of the metric window in ``series``: all (True; memory
        14 × B × N doubles), none (default: the metrics need only bounded chunks of
        designs) or the named ones (:data:`STEP_OUTPUT_NAMES`, :data:`STATE_NAMES`).
    jit : bool
        Compile the step with CasADi's C code generation when possible.
    warn : bool
        Emit :class:`RoadHoldingWarning` when η_rh > 1.
    threads : int, optional
        Threads sharing the chunks of designs (default: 2 on a multi-core machine, 1
        inside a worker process); the results do not depend on it.
    identified_range_m_per_s : float, optional
        The friction's identified range (peak stroke velocity of the bench campaign):
        the metrics then hold ``out_of_range_time_fraction`` and
        ``out_of_range_friction_energy_fraction`` (:mod:`ehsa_opt.vehicle.coverage`), and
        (``warn``) a :class:`FrictionRangeWarning` is emitted above the limit.
    sample_limits : SampleLimits, optional
        Hardware limits (screw speed, voltage, current): the metrics then hold the share
        of the time beyond each (``*_beyond_limit_fraction``; NaN without a limit).  The
        shares of tyre lift and of the stroke beyond the vehicle's limit are always there.

    Returns
    -------
    QuarterCarSimulation
    """
    if settle_s < 0.0 or not math.isfinite(settle_s):
        raise ParameterError(f"simulation: settle_s = {settle_s} must be >= 0 s")
    if not (sample_rate_hz > 0.0 and math.isfinite(sample_rate_hz)):
        raise ParameterError(f"simulation: sample_rate_hz = {sample_rate_hz} must be > 0 Hz")
    road = road or RoadParams()
    n_designs = max(len(x) if isinstance(x, Sequence) else 1 for x in (harvester, friction))
    at_once = n_designs if keep_series else min(n_designs, _MAX_CHUNK_DESIGNS)
    if isinstance(road, RoadParams) and road.profile_csv is None:  # before any allocation
        check_simulation_resources(road, sample_rate_hz, settle_s, n_designs, at_once)
    if isinstance(road, RoadParams):
        road_params: RoadParams | None = road
        profile = road_profile(road, sample_rate_hz, base_dir)
    else:
        road_params, profile = None, road
    if road_params is None or road_params.profile_csv is not None:
        check_simulation_resources(None, sample_rate_hz, settle_s, n_designs, at_once,
                                   duration_s=profile.time_s.size / sample_rate_hz)
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
    # Chunks of designs (bounded memory), shared by threads; each chunk's metrics are
    # taken from its own arrays, and its window copied out only when series are kept.
    x_pad = _padded(x_in)
    n_keep = x0_keep.size
    series = {name: np.empty((len(hs), n_keep)) for name in _series_names(keep_series)}
    _, compiled = compiled_step(float(h), jit)

    def work(sl: slice) -> dict[str, np.ndarray]:
        Z, Y = _run_designs(params[:, sl], x_pad, z0[:, sl], h, jit)
        zt, y = Z[keep].transpose(1, 2, 0), Y[keep].transpose(1, 2, 0)
        for name, arr in series.items():
            src, names = (y, STEP_OUTPUT_NAMES) if name in STEP_OUTPUT_NAMES else \
                (zt, STATE_NAMES)
            arr[sl] = src[:, names.index(name), :]
        return _window_metrics(zt, y, params[:, sl], x0_keep, h, sample_rate_hz, vehicle,
                               profile.speed_m_per_s, bound, identified_range_m_per_s,
                               sample_limits)

    t0 = time.perf_counter()
    parts = _map_threads(work, _chunks(len(hs), x_pad.size - 1), threads)
    wall = time.perf_counter() - t0
    metrics = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
    finite = all(np.all(np.isfinite(a)) for k, a in metrics.items()
                 if k not in ("dissipation_bound_W", "out_of_range_friction_energy_fraction")
                 and not k.endswith("_beyond_limit_fraction"))
    msg = "ok" if finite else "non-finite results: the step diverged (check parameters)"
    if warn:
        for b in np.flatnonzero(metrics["road_holding"] > 1.0):
            warnings.warn(f"design {b}: road holding {metrics['road_holding'][b]:.2f} > 1: the "
                          "tyre would leave the ground; the linear tyre model is invalid there",
                          RoadHoldingWarning, stacklevel=2)
        if identified_range_m_per_s is not None:
            from .coverage import coverage_warning
            for b in range(len(hs)):
                w = coverage_warning({"time_fraction": metrics["out_of_range_time_fraction"][b],
                                      "energy_fraction": metrics[
                                          "out_of_range_friction_energy_fraction"][b]},
                                     identified_range_m_per_s)
                if w:
                    warnings.warn(f"design {b}: {w}", FrictionRangeWarning, stacklevel=2)
    n_keep = x0_keep.size
    return QuarterCarSimulation(
        success=finite, message=msg, metrics=metrics, time_s=np.arange(n_keep) * h + h,
        road_m=x0_keep, series=series, vehicle=vehicle, harvesters=hs, frictions=fs_,
        road_source=profile.source,
        stats={"wall_s": wall, "steps": int(x_in.size - 1), "designs": len(hs),
               "compiled": compiled, "sample_rate_hz": float(sample_rate_hz)})
