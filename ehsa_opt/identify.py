"""Friction identification from bench tests (paper §3, SPEC §2–3 and §9).

The bench model (:class:`~ehsa_opt.models.bench.BenchModel`, any state vector,
with or without transmission components) is discretised by **direct
collocation** (Radau, degree ``d``) on a decimated grid of each test's samples;
the rod motion is prescribed from the measured displacement through a
smoothing spline (:class:`~ehsa_opt.motion.SampledMotion`) evaluated at the
collocation points; the states are initialised from the measurements and the
parameters are scaled.  **IPOPT** solves

    min  t + w · mean_k J_k      s.t.  J_k ≤ t  for every signal k of every test,
         collocation equations, bounds, F_brk ≥ F_C, T_brk ≥ T_C,

with J = mean(((S_s − S_e)/max|S_e|)²) the smooth (squared, normalised)
counterpart of the paper's Eq 5.  ``t`` is the epigraph of the minimax
max(δ_V, δ_F) of the paper; the small weight ``w`` on the mean
(:attr:`IdentifyOptions.sum_weight`) keeps the optimum unique when the
maximum is decided by a signal the parameters cannot change: on a rigid bench
the winding current obeys L di/dt = K_e v/r − R i with v prescribed, so δ_V does
not depend on friction at all.  The reported errors are Eq 5 *as printed*,
δ = sqrt(mean(|S_s − S_e| / max|S_e|)), on each test's full time grid, and the
force relative error ‖F_s − F_e‖/‖F_e‖ (EMPS reference).

Multistart: ``starts`` initial points drawn uniformly (seeded) in the
distributor ranges of SPEC §2 (components: in their ParamSpec bounds), run in
parallel processes; the best successful start is kept, every start recorded.

Identifiability: at the optimum the Gauss–Newton Fisher information of the
varied parameters (the collocation states eliminated through the sensitivity
of the collocation equations, the initial states treated as nuisance
parameters and marginalised) is eigen-decomposed in scaled coordinates;
directions with relative eigenvalue below :attr:`IdentifyOptions.identifiable_rtol`
are reported as not determined by the data, together with identifiable
combinations (rod friction at given speeds, total viscous, …) and their
95 % confidence intervals.
"""

from __future__ import annotations

import dataclasses
import math
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

import casadi as ca
import numpy as np

from .bench import simulate_bench
from .data import BenchData, BenchTest, load_bench
from .friction import rod_friction_N
from .models.bench import RIG_PARAM_NAMES, BenchModel
from .models.components import Component
from .motion import SampledMotion
from .params import FRICTION_NAMES, FRICTION_RANGES, FrictionParams, HarvesterParams

__all__ = ["IdentifyOptions", "FitResult", "Prediction", "IdentificationReport", "fit_tests",
           "simulate_tests", "eq5_delta", "force_relative_error_percent", "identify",
           "PARAMETER_BOUNDS", "START_RANGES", "fisher_identifiability"]

#: Admissible bounds (lower, upper, scale) of the parameters during identification:
#: the SPEC §2 distributor ranges' upper ends (lower ends 0 for levels and viscous terms,
#: so "no friction" stays admissible; the distributor ranges for breakaway velocities).
#: Without bounds the unmodelled backlash of the embedded data drives Stribeck bumps
#: to 1000 N at 0.2 m/s, far outside any ball screw.
PARAMETER_BOUNDS: dict[str, tuple[float, float, float]] = {
    "nut_breakaway_N": (0.0, 200.0, 100.0),
    "nut_coulomb_N": (0.0, 150.0, 100.0),
    "nut_breakaway_velocity_m_per_s": (1e-3, 5e-2, 0.01),
    "nut_viscous_Ns_per_m": (0.0, 500.0, 100.0),
    "bearing_breakaway_Nm": (0.0, 5e-2, 0.01),
    "bearing_coulomb_Nm": (0.0, 5e-2, 0.01),
    "bearing_breakaway_velocity_rad_per_s": (0.1, 5.0, 1.0),
    "bearing_viscous_Nms_per_rad": (0.0, 1e-4, 1e-5),
    "inertia_kg": (0.0, 1e4, 100.0),
    "offset_N": (-1e4, 1e4, 10.0),
}

#: Ranges the multistart draws from: SPEC §2 distributor ranges, plus the rig terms.
START_RANGES: dict[str, tuple[float, float]] = {
    **FRICTION_RANGES, "inertia_kg": (10.0, 200.0), "offset_N": (-20.0, 20.0)}

_BEARING = FRICTION_NAMES[4:]
_TIES = {"nut_breakaway_N": "nut_coulomb_N", "bearing_breakaway_Nm": "bearing_coulomb_Nm"}


# ====================================================================== options
@dataclass(frozen=True)
class IdentifyOptions:
    """Settings of the collocation NLP and IPOPT.

    Attributes
    ----------
    degree : int
        Radau collocation degree d (1–9).
    max_intervals : int
        Collocation intervals per test; longer records are decimated to this
        many intervals (nodes on measured samples).
    max_samples : int
        Samples per test entering the objective (decimated uniformly if the
        record is longer); states between nodes come from the collocation
        polynomials, so short events such as velocity reversals are not missed.
    tol : float
        IPOPT ``tol``.
    max_iter : int
        IPOPT ``max_iter``.
    sum_weight : float
        w in ``t + w·mean(J)`` (≥ 0; see the module docstring).
    objective_scale : float
        Constant factor on the objective (conditioning only).
    smoothing : float or None
        ``lam`` of the displacement smoothing spline (None: GCV).
    spline_points : int
        With GCV, the smoothing spline is fitted to at most
        max(spline_points, n/10) of a test's n displacement samples (uniformly
        decimated; GCV costs ~0.3 ms per point).
    smoothing_cutoff_hz : float or None
        If given (and ``smoothing`` is None), the spline penalty is set from an
        equivalent low-pass cut-off f_c: the smoothing spline's response is
        1/(1 + λ Δt ω⁴), so λ = 1/(Δt (2π f_c)⁴), and all samples are used.
        Default 30 Hz (the sine tests are ≤ 3.5 Hz; 2 µm displacement noise
        stays below the 2 N force noise); None selects GCV, which over-smooths
        1 kHz records (force rms error 5.8 N instead of 2.2 N at 3.5 Hz; EMPS:
        M +7 %); see :meth:`for_rig`.
    trim_fraction : float
        Fraction of each record left out of the objective at each end, where
        the spline's derivatives are least accurate (0–0.2).
    identifiable_rtol : float
        Fisher-information eigenvalues below this fraction of the largest mark
        a direction the data do not determine.
    """

    degree: int = 3
    max_intervals: int = 100
    max_samples: int = 600
    tol: float = 1e-8
    max_iter: int = 500
    sum_weight: float = 0.1
    objective_scale: float = 100.0
    smoothing: float | None = None
    spline_points: int = 600
    smoothing_cutoff_hz: float | None = 30.0
    trim_fraction: float = 0.02
    identifiable_rtol: float = 1e-6

    def __post_init__(self) -> None:
        if not (isinstance(self.degree, int) and 1 <= self.degree <= 9):
            raise ValueError(f"IdentifyOptions: degree must be an integer 1..9, got "
                             f"{self.degree!r}")
        if not (isinstance(self.max_intervals, int) and self.max_intervals >= 4):
            raise ValueError("IdentifyOptions: max_intervals must be an integer >= 4, got "
                             f"{self.max_intervals!r}")
        if not (isinstance(self.max_samples, int) and self.max_samples >= 5):
            raise ValueError("IdentifyOptions: max_samples must be an integer >= 5, got "
                             f"{self.max_samples!r}")
        if not (isinstance(self.spline_points, int) and self.spline_points >= 10):
            raise ValueError("IdentifyOptions: spline_points must be an integer >= 10, got "
                             f"{self.spline_points!r}")
        if not (isinstance(self.max_iter, int) and self.max_iter >= 1):
            raise ValueError(f"IdentifyOptions: max_iter must be an integer >= 1, got "
                             f"{self.max_iter!r}")
        for name in ("tol", "objective_scale", "identifiable_rtol"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"IdentifyOptions: {name} must be > 0, got {v!r}")
        if not (isinstance(self.sum_weight, (int, float)) and self.sum_weight >= 0):
            raise ValueError(f"IdentifyOptions: sum_weight must be >= 0, got {self.sum_weight!r}")
        if not (0.0 <= self.trim_fraction < 0.2):
            raise ValueError("IdentifyOptions: trim_fraction must be in [0, 0.2), got "
                             f"{self.trim_fraction!r}")
        if self.smoothing is not None and not self.smoothing >= 0:
            raise ValueError("IdentifyOptions: smoothing must be None or >= 0")
        if self.smoothing_cutoff_hz is not None and not self.smoothing_cutoff_hz > 0:
            raise ValueError("IdentifyOptions: smoothing_cutoff_hz must be None or > 0 (Hz)")

    @classmethod
    def for_rig(cls, has_generator: bool, **changes: Any) -> "IdentifyOptions":
        """Defaults per rig: a 30 Hz smoothing cut-off for the sine bench tests; for
        rigs without generator (recorded motion, e.g. EMPS at 1 kHz) 60 Hz (which
        reproduces the published EMPS inertia) and up to 5000 objective samples."""
        base: dict[str, Any] = {} if has_generator else {"smoothing_cutoff_hz": 60.0,
                                                         "max_samples": 5000}
        base.update(changes)
        return cls(**base)


# ====================================================================== metrics
def eq5_delta(simulated: Any, measured: Any) -> float:
    """Paper Eq 5 as printed: δ = sqrt( (1/N) Σ |(S_s − S_e) / max|S_e|| )."""
    s, m = np.asarray(simulated, float), np.asarray(measured, float)
    if s.shape != m.shape or s.size == 0:
        raise ValueError(f"eq5_delta: shapes differ or empty ({s.shape} vs {m.shape})")
    return float(np.sqrt(np.mean(np.abs((s - m) / np.max(np.abs(m))))))


def force_relative_error_percent(simulated: Any, measured: Any) -> float:
    """‖F_s − F_e‖₂ / ‖F_e‖₂ in % (the EMPS reference's figure of merit)."""
    s, m = np.asarray(simulated, float), np.asarray(measured, float)
    if s.shape != m.shape or s.size == 0:
        raise ValueError(f"force_relative_error_percent: shapes differ ({s.shape} vs {m.shape})")
    return float(100.0 * np.linalg.norm(s - m) / np.linalg.norm(m))


# ====================================================================== results
@dataclass
class Prediction:
    """Simulated signals of one test on its own time grid."""

    file: str
    time_s: np.ndarray
    force_N: np.ndarray
    voltage_V: np.ndarray | None


@dataclass
class FitResult:
    """Result of :func:`fit_tests` (mirrors ``scipy.optimize.OptimizeResult``).

    Attributes
    ----------
    success : bool
        True if at least one start converged (IPOPT success).
    message : str
    status : str
        IPOPT ``return_status`` of the kept start.
    parameters : dict[str, float]
        Every model parameter except ``load_ohm`` (NaN if no start succeeded).
    delta_F, delta_V : float or None
        Paper Eq 5 (as printed) over all the fitted tests' samples (δ_V None
        without voltage); max over tests.
    force_relative_error_percent : float or None
    per_test : list[dict]
        file, delta_F, delta_V, force_relative_error_percent per test.
    starts : list[dict]
        Every start: initial, final, objective, success, status, iterations, seconds.
    history : dict
        Best start per iteration: ``objective``, ``rms_F``, ``rms_V`` (lists),
        ``parameters`` (name → list).
    nit : int
    varied : list[str]
    identifiability : dict or None
        See :func:`fisher_identifiability`.
    """

    success: bool
    message: str
    status: str
    parameters: dict[str, float]
    delta_F: float | None
    delta_V: float | None
    force_relative_error_percent: float | None
    per_test: list[dict]
    starts: list[dict]
    history: dict
    nit: int
    varied: list[str] = field(default_factory=list)
    identifiability: dict | None = None
    objective: float = math.nan
    seconds: float = 0.0

    def __getitem__(self, key: str) -> Any:  # OptimizeResult-like access
        return getattr(self, key)

    def plot(self, tests: Sequence[BenchTest] | None = None, harvester: Any = None,
             **kw: Any) -> Any:
        """Figures 8–9 (and 11 when ``tests`` are given); see :mod:`ehsa_opt.plots.identify`."""
        from .plots import identify as P
        return P.fit_result(self, tests=tests, harvester=harvester, **kw)


# ====================================================================== problem
@dataclass
class _Problem:
    """Plain, picklable description of one identification NLP."""

    tests: list[BenchTest]
    harvester: HarvesterParams
    has_generator: bool
    components: list[Component]
    varied: list[str]
    fixed: dict[str, Any]
    options: IdentifyOptions
    motions: list[SampledMotion] = field(default_factory=list)

    def model(self) -> BenchModel:
        return BenchModel(self.harvester, self.components, generator=self.has_generator)


def _defaults(model: BenchModel) -> dict[str, float]:
    d = FrictionParams().as_dict()
    if not model.generator:
        d.update({"inertia_kg": 0.0, "offset_N": 0.0})
    d.update({q.name: q.default for q in model.param_specs.values()})
    return d


def _bounds(model: BenchModel, name: str) -> tuple[float, float, float]:
    if name in PARAMETER_BOUNDS:
        return PARAMETER_BOUNDS[name]
    q = model.param_specs[name]
    scale = abs(q.default) if q.default != 0 else max(abs(q.upper), abs(q.lower), 1e-12)
    return q.lower, q.upper, scale


def _draw_start(model: BenchModel, varied: Sequence[str], rng: np.random.Generator,
                k: int) -> dict[str, float]:
    """Start k: friction uniform in the distributor ranges, components at their
    defaults for k = 0 and drawn in their bounds otherwise (log-uniform when the
    bounds span more than two decades)."""
    out = {}
    for n in varied:
        if n in START_RANGES:
            lo, hi = START_RANGES[n]
            out[n] = float(rng.uniform(lo, hi))
        else:
            q = model.param_specs[n]
            if k == 0:
                out[n] = q.default
            elif q.lower > 0 and q.upper / q.lower > 100:
                out[n] = float(np.exp(rng.uniform(np.log(q.lower), np.log(q.upper))))
            else:
                out[n] = float(rng.uniform(q.lower, q.upper))
    for brk, coul in _TIES.items():
        if brk in out and coul in out and out[brk] < out[coul]:
            out[brk], out[coul] = out[coul], out[brk]
    return out


def _node_indices(n: int, max_intervals: int) -> np.ndarray:
    if n - 1 <= max_intervals:
        return np.arange(n)
    return np.unique(np.round(np.linspace(0, n - 1, max_intervals + 1)).astype(int))


def _radau(d: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, list]:
    tau = np.append(0.0, ca.collocation_points(d, "radau"))
    C = np.zeros((d + 1, d + 1))
    D = np.zeros(d + 1)
    basis = []
    for j in range(d + 1):
        p = np.poly1d([1.0])
        for r in range(d + 1):
            if r != j:
                p *= np.poly1d([1.0, -tau[r]]) / (tau[j] - tau[r])
        D[j] = p(1.0)
        basis.append(p)
        dp = np.polyder(p)
        for r in range(d + 1):
            C[j, r] = dp(tau[r])
    return tau, C, D, basis


def _interp_matrix(t_nodes: np.ndarray, t_obs: np.ndarray, d: int, basis: list) -> Any:
    """Sparse matrix M with X_obs = [Xn | Xc] · M: the collocation polynomial of each
    interval evaluated at the observation times (columns of Xn first, then Xc)."""
    N = t_nodes.size - 1
    k = np.clip(np.searchsorted(t_nodes, t_obs, side="right") - 1, 0, N - 1)
    tau = (t_obs - t_nodes[k]) / (t_nodes[k + 1] - t_nodes[k])
    rows, cols, vals = [], [], []
    for m, (kk, tt) in enumerate(zip(k, tau)):
        for j in range(d + 1):
            rows.append(kk if j == 0 else (N + 1) + kk * d + (j - 1))
            cols.append(m)
            vals.append(basis[j](tt))
    sp = ca.Sparsity.triplet((N + 1) + d * N, t_obs.size, rows, cols)
    return ca.DM(sp, np.array(vals))


class _Recorder(ca.Callback):
    """IPOPT iteration callback storing the decision vector of each iteration."""

    def __init__(self, nx: int, ng: int) -> None:
        ca.Callback.__init__(self)
        self.nx, self.ng = nx, ng
        self.rows: list[np.ndarray] = []
        self.construct("recorder", {})

    def get_n_in(self) -> int:
        return ca.nlpsol_n_out()

    def get_n_out(self) -> int:
        return 1

    def get_name_in(self, i: int) -> str:
        return ca.nlpsol_out(i)

    def get_name_out(self, i: int) -> str:
        return "ret"

    def get_sparsity_in(self, i: int) -> Any:
        n = ca.nlpsol_out(i)
        if n == "f":
            return ca.Sparsity.scalar()
        if n in ("x", "lam_x"):
            return ca.Sparsity.dense(self.nx)
        if n in ("g", "lam_g"):
            return ca.Sparsity.dense(self.ng)
        return ca.Sparsity(0, 0)

    def eval(self, arg: Any) -> list:
        self.rows.append(np.array(arg[0]).ravel().copy())
        return [0]


class _NLP:
    """The collocation NLP of a :class:`_Problem` (built once, solved per start)."""

    def __init__(self, prob: _Problem) -> None:
        self.prob = prob
        opt = prob.options
        model = self.model = prob.model()
        self.defaults = _defaults(model)
        names = [n for n in model.param_names if n != "load_ohm"]
        for n in prob.varied:
            if n not in names:
                raise ValueError(f"fit_tests: cannot vary unknown parameter '{n}' "
                                 f"(known: {', '.join(names)})")
        nv = len(prob.varied)
        self.bnd = {n: _bounds(model, n) for n in prob.varied}
        z = ca.SX.sym("z", nv)
        pexpr: dict[str, Any] = {}
        for k, n in enumerate(prob.varied):
            pexpr[n] = self.bnd[n][2] * z[k]
        for n in names:
            if n in pexpr:
                continue
            v = prob.fixed.get(n, self.defaults[n])
            if not isinstance(v, str):
                pexpr[n] = ca.SX(float(v))
        for n in names:  # ties ("equal to parameter X")
            if n not in pexpr:
                other = prob.fixed[n]
                if other not in pexpr:
                    raise ValueError(f"fit_tests: '{n}' is tied to '{other}', which is unknown")
                pexpr[n] = pexpr[other]
        self.pexpr = pexpr
        self.names = names
        self.pfun = ca.Function("params", [z], [ca.vertcat(*[pexpr[n] for n in names])])

        nx, d = model.n_states, opt.degree
        tau, C, D, basis = _radau(d)
        xs_k = ca.SX.sym("xk", nx)
        xc = ca.SX.sym("xc", nx, d)
        uc = ca.SX.sym("uc", 3, d)
        ps = ca.SX.sym("p", len(model.param_names))
        hs = ca.SX.sym("h")
        eqs, xend = [], D[0] * xs_k
        for j in range(1, d + 1):
            xp = C[0, j] * xs_k
            for r in range(1, d + 1):
                xp = xp + C[r, j] * xc[:, r - 1]
            f = model.ode(xc[:, j - 1], uc[:, j - 1], ps)
            eqs.append(hs * f - xp)
            xend = xend + D[j] * xc[:, j - 1]
        interval = ca.Function("interval", [xs_k, xc, uc, ps, hs],
                               [ca.vertcat(*eqs) if eqs else ca.SX(0, 1), xend])

        w, w0, g, lbg, ubg = [z], [], [], [], []
        self.x_slices: list[tuple[slice, int, int]] = []
        Js: list[Any] = []
        self.J_labels: list[tuple[str, str]] = []
        self.y_meas: list[np.ndarray] = []
        y_exprs: list[Any] = []
        self.node_t: list[np.ndarray] = []
        self.n_obs: list[int] = []
        self.x_init: list[np.ndarray] = []
        self.motions: list[SampledMotion] = []
        offset = nv
        for test in prob.tests:
            idx = _node_indices(test.n_samples, opt.max_intervals)
            t_nodes = test.time_s[idx]
            N = idx.size - 1
            h = np.diff(t_nodes)
            motion = prob.motions[len(self.motions)]
            self.motions.append(motion)
            t_col = (t_nodes[:-1, None] + h[:, None] * tau[None, 1:]).ravel()
            u_nodes = motion.evaluate(t_nodes)
            u_col = motion.evaluate(t_col)
            load = test.load_ohm if (test.load_ohm is not None and prob.has_generator) else 1.0
            P = ca.vertcat(ca.SX(load), *[pexpr[n] for n in names])
            Xn = ca.SX.sym(f"Xn_{len(self.x_slices)}", nx, N + 1)
            Xc = ca.SX.sym(f"Xc_{len(self.x_slices)}", nx, d * N)
            p0 = np.array([load])  # initial_state reads only the load
            xin = np.array([model.initial_state(u_nodes[:, k], p0) for k in range(N + 1)]).T \
                if nx else np.zeros((0, N + 1))
            xic = np.array([model.initial_state(u_col[:, k], p0) for k in range(d * N)]).T \
                if nx else np.zeros((0, d * N))
            if nx:
                w += [ca.vec(Xn), ca.vec(Xc)]
                w0 += [xin.ravel(order="F"), xic.ravel(order="F")]
                self.x_slices.append((slice(offset, offset + nx * (N + 1)), nx, N + 1))
                offset += nx * (N + 1) + nx * d * N
                # map: block k of Xc / u_col is columns k·d … k·d + d − 1 (interval k)
                eq, xe = interval.map(N)(Xn[:, :-1], Xc, ca.DM(u_col), P, ca.DM(h).T)
                g += [ca.vec(eq), ca.vec(Xn[:, 1:] - xe)]
                nn = nx * d * N + nx * N
                lbg += [np.zeros(nn)]
                ubg += [np.zeros(nn)]
            else:
                self.x_slices.append((slice(offset, offset), 0, N + 1))
            ntrim = int(round(opt.trim_fraction * test.n_samples))
            obs = np.arange(ntrim, test.n_samples - ntrim)
            obs = obs[_node_indices(obs.size, opt.max_samples - 1)]
            t_obs = test.time_s[obs]
            n_obs = obs.size
            u_obs = motion.evaluate(t_obs)
            if nx:
                M = _interp_matrix(t_nodes, t_obs, d, basis)
                X_obs = ca.mtimes(ca.horzcat(Xn, Xc), M)
            else:
                X_obs = ca.SX(0, n_obs)
            y = model.outputs.map(n_obs)(X_obs, ca.DM(u_obs), P)
            y_exprs.append(y)
            self.n_obs.append(n_obs)
            self.node_t.append(t_nodes)
            self.x_init.append(xin)
            sel = np.arange(n_obs)
            Fm = test.force_N[obs]
            JF = ca.sumsqr((y[0, sel].T - Fm[sel]) / np.max(np.abs(test.force_N))) / sel.size
            Js.append(JF)
            self.J_labels.append((test.file, "F"))
            ym = [Fm]
            if test.voltage_V is not None and prob.has_generator:
                Vm = test.voltage_V[obs]
                JV = ca.sumsqr((y[1, sel].T - Vm[sel]) / np.max(np.abs(test.voltage_V))) \
                    / sel.size
                Js.append(JV)
                self.J_labels.append((test.file, "V"))
                ym.append(Vm)
            self.y_meas.append(np.array(ym))
        tvar = ca.SX.sym("t")
        w.append(tvar)
        self.t_index = offset
        self.nw = offset + 1
        Jv = ca.vertcat(*Js)
        g.append(Jv - tvar)
        lbg.append(-np.inf * np.ones(len(Js)))
        ubg.append(np.zeros(len(Js)))
        self.n_ineq = len(Js)
        # F_brk >= F_C, T_brk >= T_C whenever one of them varies
        for brk, coul in _TIES.items():
            if brk in prob.varied or coul in prob.varied:
                g.append(pexpr[brk] - pexpr[coul])
                lbg.append(np.zeros(1))
                ubg.append(np.inf * np.ones(1))
        W = ca.vertcat(*w)
        G = ca.vertcat(*g)
        obj = opt.objective_scale * (tvar + opt.sum_weight * ca.sum1(Jv) / len(Js))
        self.lbg, self.ubg = np.concatenate(lbg), np.concatenate(ubg)
        self.w_states0 = np.concatenate(w0) if w0 else np.zeros(0)
        self.Jfun = ca.Function("J", [W], [Jv])
        self.yfun = ca.Function("y", [W], [ca.vertcat(*[ca.vec(y.T) for y in y_exprs])])
        self.W, self.G = W, G
        self.recorder = _Recorder(self.nw, G.numel())
        ipopt = {"tol": opt.tol, "max_iter": opt.max_iter, "print_level": 0, "sb": "yes",
                 "mu_strategy": "adaptive"}
        self.solver = ca.nlpsol("identify", "ipopt", {"x": W, "f": obj, "g": G},
                                {"ipopt": ipopt, "print_time": False,
                                 "iteration_callback": self.recorder})
        lbw = np.full(self.nw, -np.inf)
        ubw = np.full(self.nw, np.inf)
        for k, n in enumerate(prob.varied):
            lo, hi, sc = self.bnd[n]
            lbw[k], ubw[k] = lo / sc, hi / sc
        lbw[self.t_index] = 0.0
        self.lbw, self.ubw = lbw, ubw

    # -------------------------------------------------------------- solve
    def x0(self, start: Mapping[str, float]) -> np.ndarray:
        z0 = np.array([start[n] / self.bnd[n][2] for n in self.prob.varied])
        w0 = np.concatenate([z0, self.w_states0, [0.0]])
        w0[self.t_index] = float(np.max(np.array(self.Jfun(w0)).ravel()))
        return w0

    def params_of(self, w: np.ndarray) -> dict[str, float]:
        z = np.clip(w[:len(self.prob.varied)], self.lbw[:len(self.prob.varied)],
                    self.ubw[:len(self.prob.varied)])  # IPOPT may sit 1e-12 outside
        p = np.array(self.pfun(z)).ravel()
        return {n: float(v) for n, v in zip(self.names, p)}

    def solve(self, start: Mapping[str, float]) -> dict:
        self.recorder.rows = []
        t0 = time.perf_counter()
        try:
            sol = self.solver(x0=self.x0(start), lbx=self.lbw, ubx=self.ubw, lbg=self.lbg,
                              ubg=self.ubg)
            st = self.solver.stats()
            ok, status = bool(st.get("success", False)), str(st.get("return_status", "?"))
            w = np.array(sol["x"]).ravel()
            f = float(sol["f"])
            nit = int(st.get("iter_count", len(self.recorder.rows)))
        except RuntimeError as exc:  # evaluation errors
            ok, status, w, f, nit = False, f"error: {exc}", self.x0(start), math.nan, 0
        secs = time.perf_counter() - t0
        hist_w = self.recorder.rows or [w]
        history = self._history(hist_w)
        params = self.params_of(w)
        if not np.all(np.isfinite(w)):
            ok = False
        return {"initial": dict(start), "final": params, "objective": f, "success": ok,
                "status": status, "iterations": nit, "seconds": secs, "w": w,
                "history": history}

    def _history(self, rows: list[np.ndarray]) -> dict:
        J = np.array([np.array(self.Jfun(r)).ravel() for r in rows])
        isF = np.array([lab[1] == "F" for lab in self.J_labels])
        opt = self.prob.options
        obj = opt.objective_scale * (np.max(J, axis=1) + opt.sum_weight * J.mean(axis=1))
        pars = [self.params_of(r) for r in rows]
        return {"objective": obj.tolist(),
                "rms_F": np.sqrt(J[:, isF].max(axis=1)).tolist(),
                "rms_V": (np.sqrt(J[:, ~isF].max(axis=1)).tolist() if (~isF).any() else None),
                "parameters": {n: [p[n] for p in pars] for n in self.prob.varied}}

    # -------------------------------------------------------------- identifiability
    def sensitivities(self, w: np.ndarray) -> tuple[np.ndarray, list[np.ndarray]]:
        """d(outputs at nodes)/d(varied parameters, physical units), states eliminated.

        Returns the Jacobian (n_y × n_varied) and, per test, the rows of its outputs.
        Initial states are extra nuisance columns, returned after the parameters.
        """
        import scipy.sparse as sp
        import scipy.sparse.linalg as spla

        nv = len(self.prob.varied)
        Wsym = self.W
        # equality constraints = collocation + continuity (everything before the J rows)
        n_eq = self.G.numel() - self.n_ineq - sum(
            1 for b, c in _TIES.items() if b in self.prob.varied or c in self.prob.varied)
        Geq = self.G[:n_eq] if n_eq else ca.SX(0, 1)
        y = self.yfun(Wsym)
        jy = ca.Function("jy", [Wsym], [ca.jacobian(y, Wsym)])
        Jy = sp.csc_matrix(np.array(jy(w)))
        x0_cols, state_cols = [], []
        for sl, nx, npts in self.x_slices:
            if nx:
                x0_cols += list(range(sl.start, sl.start + nx))
                allc = list(range(sl.start, sl.start + nx * npts))
                ncoll = nx * self.prob.options.degree * (npts - 1)
                allc += list(range(sl.stop, sl.stop + ncoll))
                state_cols += [c for c in allc if c not in set(x0_cols[-nx:])]
        theta_cols = list(range(nv)) + x0_cols
        if n_eq and state_cols:
            jg = ca.Function("jg", [Wsym], [ca.jacobian(Geq, Wsym)])
            Jg = jg(w).sparse().tocsc()
            Gs = Jg[:, state_cols]
            Gt = Jg[:, theta_cols].toarray()
            S = spla.splu(Gs.tocsc()).solve(-Gt)
            dy = Jy[:, theta_cols].toarray() + Jy[:, state_cols] @ S
        else:
            dy = Jy[:, theta_cols].toarray()
        scales = np.array([self.bnd[n][2] for n in self.prob.varied])
        dy[:, :nv] /= scales  # d/dz -> d/dp (physical units)
        return dy, theta_cols


# ====================================================================== workers
def _run_starts(prob: _Problem, starts: list[dict[str, float]], ident: bool = True
                ) -> list[dict]:
    """Build the NLP once, solve every start; Fisher analysis at the chunk's best."""
    nlp = _NLP(prob)
    recs = [nlp.solve(s) for s in starts]
    ok = [r for r in recs if r["success"]]
    if ident and ok:
        best = min(ok, key=lambda r: r["objective"])
        try:
            best["ident"] = fisher_identifiability(nlp, best["w"])
        except (RuntimeError, np.linalg.LinAlgError, ValueError) as exc:
            best["ident"] = {"error": str(exc)}
    return recs


def _pool(jobs: int) -> ProcessPoolExecutor:
    import multiprocessing as mp
    return ProcessPoolExecutor(max_workers=jobs, mp_context=mp.get_context("fork"))


def test_motion(test: BenchTest, options: IdentifyOptions | None = None) -> SampledMotion:
    """Prescribed motion of a test: smoothing spline of its measured displacement,
    fitted to at most max(spline_points, n/10) uniformly decimated samples."""
    opt = options or IdentifyOptions()
    n = test.n_samples
    if opt.smoothing is None and opt.smoothing_cutoff_hz is not None:
        return SampledMotion.with_cutoff(test.time_s, test.displacement_m,
                                         opt.smoothing_cutoff_hz)
    m = n if opt.smoothing is not None else min(n, max(opt.spline_points, n // 10))
    idx = _node_indices(n, m - 1)
    return SampledMotion(test.time_s[idx], test.displacement_m[idx], opt.smoothing)


# ====================================================================== simulation
def simulate_tests(tests: Sequence[BenchTest], harvester: HarvesterParams,
                   parameters: Mapping[str, float], *, has_generator: bool = True,
                   components: Sequence[Component] = (),
                   options: IdentifyOptions | None = None,
                   motions: Sequence[SampledMotion] | None = None) -> list[Prediction]:
    """Simulate each test with given parameters on its own time grid.

    The rod motion is the smoothing spline of the measured displacement
    (:func:`test_motion`, or ``motions`` when given); missing parameters take
    their defaults (frictionless, component defaults, M = F_0 = 0).
    """
    model = BenchModel(harvester, components, generator=has_generator)
    base = _defaults(model)
    unknown = [k for k in parameters if k not in base and k != "load_ohm"]
    if unknown:
        raise ValueError(f"simulate_tests: unknown parameter(s) {', '.join(unknown)} "
                         f"(known: {', '.join(base)})")
    base.update({k: float(v) for k, v in parameters.items() if k != "load_ohm"})
    out = []
    for k, test in enumerate(tests):
        load = test.load_ohm if (test.load_ohm is not None and has_generator) else 1.0
        p = np.array([load, *[base[n] for n in model.param_names[1:]]])
        motion = motions[k] if motions is not None else test_motion(test, options)
        if model.n_states == 0:
            uu = motion.evaluate(test.time_s)
            y = np.array(model.outputs.map(test.n_samples)(np.zeros((0, test.n_samples)), uu, p))
            F, V = y[0], y[1]
        else:
            sim = simulate_bench(model, motion, p, test.time_s, rtol=1e-7, atol=1e-9)
            F, V = sim.force_N, sim.voltage_V
        out.append(Prediction(test.file, test.time_s, F,
                              V if (has_generator and test.voltage_V is not None) else None))
    return out


def _test_errors(tests: Sequence[BenchTest], preds: Sequence[Prediction]) -> list[dict]:
    rows = []
    for t, pr in zip(tests, preds):
        rows.append({"file": t.file,
                     "delta_F": eq5_delta(pr.force_N, t.force_N),
                     "delta_V": (eq5_delta(pr.voltage_V, t.voltage_V)
                                 if pr.voltage_V is not None else None),
                     "force_relative_error_percent": force_relative_error_percent(pr.force_N,
                                                                                  t.force_N)})
    return rows


# ====================================================================== fit
def _default_vary(model: BenchModel, has_generator: bool, fixed: Mapping[str, Any]) -> list[str]:
    names = [n for n in model.param_names if n != "load_ohm"]
    if not has_generator:  # friction reported under the nut_* names; no bearings
        names = [n for n in names if n not in _BEARING]
    return [n for n in names if n not in fixed]


def fit_tests(tests: Sequence[BenchTest], harvester: HarvesterParams, *,
              has_generator: bool = True, components: Sequence[Component] = (),
              vary: Sequence[str] | None = None, fixed: Mapping[str, Any] | None = None,
              starts: int = 4, seed: int = 0, jobs: int = 1,
              options: IdentifyOptions | None = None, identifiability: bool = True
              ) -> FitResult:
    """Identify ONE parameter set for all the given tests (per-test fit: one test).

    Parameters
    ----------
    tests : sequence of BenchTest
    harvester : HarvesterParams
    has_generator : bool
        False for rigs without generator: ``inertia_kg`` and ``offset_N`` are
        identified beside the nut friction; the bearing friction is fixed at 0.
    components : sequence of Component
        Extra effects; their parameters vary in their ParamSpec bounds by default.
    vary : sequence of str, optional
        Names to vary (default: every parameter but ``load_ohm``; without
        generator, not the bearing names).
    fixed : mapping, optional
        Name → value; a string value ties the parameter to another one
        (e.g. ``{"nut_breakaway_N": "nut_coulomb_N"}`` removes the Stribeck bump).
    starts, seed, jobs : int
        Multistart size, seed of the draws, parallel processes.
    options : IdentifyOptions
    identifiability : bool
        Compute the Fisher-information analysis at the optimum.

    Returns
    -------
    FitResult
    """
    tests = list(tests)
    if not tests:
        raise ValueError("fit_tests: no tests given")
    if not (isinstance(starts, int) and starts >= 1):
        raise ValueError(f"fit_tests: starts must be an integer >= 1, got {starts!r}")
    if not (isinstance(jobs, int) and jobs >= 1):
        raise ValueError(f"fit_tests: jobs must be an integer >= 1, got {jobs!r}")
    if has_generator and any(t.voltage_V is None for t in tests):
        bad = next(t.file for t in tests if t.voltage_V is None)
        raise ValueError(f"fit_tests: {bad} has no voltage_V but has_generator=True; pass "
                         f"has_generator=False for a rig without generator")
    options = options or IdentifyOptions()
    fixed = dict(fixed or {})
    model = BenchModel(harvester, components, generator=has_generator)
    known = [n for n in model.param_names if n != "load_ohm"]
    for n, v in fixed.items():
        if n not in known:
            raise ValueError(f"fit_tests: fixed parameter '{n}' is unknown (known: "
                             f"{', '.join(known)})")
        if isinstance(v, str) and v not in known:
            raise ValueError(f"fit_tests: '{n}' tied to unknown parameter '{v}'")
    if not has_generator:
        for n in _BEARING:
            fixed.setdefault(n, 1.0 if "velocity" in n else 0.0)
    varied = list(vary) if vary is not None else _default_vary(model, has_generator, fixed)
    clash = [n for n in varied if n in fixed]
    if clash:
        raise ValueError(f"fit_tests: {', '.join(clash)} both varied and fixed")
    prob = _Problem(tests, harvester, has_generator, list(components), varied, fixed, options,
                    [test_motion(t, options) for t in tests])
    rng = np.random.default_rng(seed)
    draws = [_draw_start(model, varied, rng, k) for k in range(starts)]
    t0 = time.perf_counter()
    if jobs == 1 or starts == 1:
        records = _run_starts(prob, draws, identifiability)
    else:
        chunks = [draws[k::jobs] for k in range(min(jobs, starts))]
        order = [k for j in range(len(chunks)) for k in range(j, starts, jobs)]
        with _pool(len(chunks)) as ex:
            parts = list(ex.map(_run_starts, [prob] * len(chunks), chunks,
                                [identifiability] * len(chunks)))
        flat = [r for part in parts for r in part]
        records = [None] * starts
        for k, r in zip(order, flat):
            records[k] = r
    return _finish(prob, records, time.perf_counter() - t0, identifiability)


def _finish(prob: _Problem, records: list[dict], seconds: float,
            identifiability: bool) -> FitResult:
    ok = [r for r in records if r["success"]]
    starts_out = [{k: v for k, v in r.items() if k not in ("w", "history", "ident")}
                  for r in records]
    names = [n for n in prob.model().param_names if n != "load_ohm"]
    if not ok:
        best = min(records, key=lambda r: r["objective"] if math.isfinite(r["objective"])
                   else math.inf)
        return FitResult(False, f"all {len(records)} IPOPT starts failed (statuses: "
                         f"{sorted({r['status'] for r in records})})", best["status"],
                         {n: math.nan for n in names}, None, None, None, [], starts_out,
                         best["history"], best["iterations"], list(prob.varied), None,
                         math.nan, seconds)
    best = min(ok, key=lambda r: r["objective"])
    params = best["final"]
    preds = simulate_tests(prob.tests, prob.harvester, params, has_generator=prob.has_generator,
                           components=prob.components, motions=prob.motions)
    per = _test_errors(prob.tests, preds)
    dF = max(r["delta_F"] for r in per)
    dV = max(r["delta_V"] for r in per) if all(r["delta_V"] is not None for r in per) else None
    Fs = np.concatenate([p.force_N for p in preds])
    Fe = np.concatenate([t.force_N for t in prob.tests])
    rel = force_relative_error_percent(Fs, Fe)
    ident = best.get("ident") if identifiability else None
    msg = (f"{len(ok)}/{len(records)} starts converged; best objective {best['objective']:.6g} "
           f"({best['status']})")
    return FitResult(True, msg, best["status"], params, dF, dV, rel, per, starts_out,
                     best["history"], best["iterations"], list(prob.varied), ident,
                     best["objective"], seconds)


# ====================================================================== identifiability
def fisher_identifiability(nlp: _NLP, w: np.ndarray, velocities_m_per_s: Sequence[float]
                           | None = None) -> dict:
    """Gauss–Newton Fisher information of the varied parameters at the optimum ``w``.

    Residuals are weighted by the noise level estimated from the fit residual
    of each signal; the initial states are marginalised (Schur complement).
    Eigen-decomposition in scaled coordinates z = p / scale (scales of
    :data:`PARAMETER_BOUNDS`).  Returns eigenvalues, directions, the names of
    the poorly determined directions, the covariance-based 95 % intervals of the
    parameters and of identifiable combinations.
    """
    prob = nlp.prob
    varied = list(prob.varied)
    nv = len(varied)
    dy, _ = nlp.sensitivities(w)
    y = np.array(nlp.yfun(w)).ravel()
    # residuals in the order of yfun: per test, vec(y.T) = [F nodes..., V nodes...]
    rows, weights, pos = [], [], 0
    for ym, npts in zip(nlp.y_meas, nlp.n_obs):
        for k in range(2):
            block = slice(pos, pos + npts)
            if k < ym.shape[0]:
                r = y[block] - ym[k]
                sigma = max(float(np.std(r)), 1e-12)
                rows.append(np.arange(block.start, block.stop))
                weights.append(np.full(npts, 1.0 / sigma))
            pos += npts
    rows_i = np.concatenate(rows)
    Wt = np.concatenate(weights)
    Jw = dy[rows_i] * Wt[:, None]
    Fall = Jw.T @ Jw
    Fpp, Fpx, Fxx = Fall[:nv, :nv], Fall[:nv, nv:], Fall[nv:, nv:]
    Fp = Fpp - Fpx @ np.linalg.pinv(Fxx) @ Fpx.T if Fxx.size else Fpp
    Fp = 0.5 * (Fp + Fp.T)
    scales = np.array([nlp.bnd[n][2] for n in varied])
    Fz = Fp * np.outer(scales, scales)
    ev, V = np.linalg.eigh(Fz)
    order = np.argsort(ev)
    ev, V = ev[order], V[:, order]
    rel = ev / max(ev[-1], 1e-300)
    rtol = prob.options.identifiable_rtol
    directions = []
    for k in range(nv):
        comp = {n: float(V[j, k]) for j, n in enumerate(varied)}
        main = {n: c for n, c in sorted(comp.items(), key=lambda kv: -abs(kv[1]))
                if abs(c) > 0.1}
        directions.append({"relative_eigenvalue": float(max(rel[k], 0.0)), "vector": comp,
                           "main": main, "identifiable": bool(rel[k] >= rtol)})
    cov_z = np.linalg.pinv(Fz, rcond=rtol)
    cov = cov_z * np.outer(scales, scales)
    params = nlp.params_of(w)
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    ci = {n: [params[n] - 1.96 * sd[j], params[n] + 1.96 * sd[j]] for j, n in enumerate(varied)}
    # identifiable combinations (rod friction at speeds, totals) with delta-method CIs
    combos = {}
    h = prob.harvester
    r = h.lead_m_per_rad

    def grad(fun: Callable[[dict], float]) -> tuple[float, np.ndarray]:
        base = fun(params)
        g = np.zeros(nv)
        for j, n in enumerate(varied):
            step = 1e-6 * scales[j]
            q = dict(params)
            q[n] += step
            g[j] = (fun(q) - base) / step
        return base, g

    def add(name: str, fun: Callable[[dict], float]) -> None:
        val, g = grad(fun)
        s = float(np.sqrt(max(g @ cov @ g, 0.0)))
        combos[name] = {"value": val, "ci95": [val - 1.96 * s, val + 1.96 * s]}

    fr_names = [n for n in FRICTION_NAMES if n in varied]
    if fr_names:
        vmax = max(float(np.max(np.abs(m.evaluate(m.time_s)[1]))) for m in nlp.motions)
        vel = velocities_m_per_s if velocities_m_per_s is not None else \
            [f * vmax for f in (0.1, 0.25, 0.5, 1.0)]

        def rod(v: float) -> Callable[[dict], float]:
            return lambda q: float(rod_friction_N(v, [q[n] for n in FRICTION_NAMES], r))
        for v in vel:
            add(f"rod_friction_N_at_{v:.4g}_m_per_s", rod(float(v)))
        add("total_viscous_Ns_per_m",
            lambda q: q["nut_viscous_Ns_per_m"] + q["bearing_viscous_Nms_per_rad"] / r ** 2)
        add("total_coulomb_N", lambda q: q["nut_coulomb_N"] + q["bearing_coulomb_Nm"] / r)
    for n in RIG_PARAM_NAMES:
        if n in varied:
            add(n, lambda q, n=n: q[n])
    weak = [d for d in directions if not d["identifiable"]]
    return {"method": "Gauss-Newton Fisher information, states eliminated by collocation "
                      "sensitivities, initial states marginalised; scaled coordinates",
            "parameters": varied, "relative_eigenvalues": [d["relative_eigenvalue"]
                                                            for d in directions],
            "directions": directions,
            "non_identifiable": [d["main"] for d in weak],
            "condition_number": float(ev[-1] / max(ev[0], 1e-300)), "threshold": rtol,
            "parameter_ci95": ci, "combinations": combos}


# ====================================================================== identify
@dataclass
class IdentificationReport:
    """Result of :func:`identify`: per-test fits, bounds, identifiability, joint fit.

    Attributes
    ----------
    data : BenchData
    fits : list[FitResult]
        One per test (paper procedure).
    bounds : dict[str, list[float]]
        Min and max of each parameter over the successful per-test fits (Table 2).
    joint : FitResult or None
        One parameter set for the training tests.
    holdout_files : list[str]
    holdout_errors : list[dict]
        Eq 5 and relative error of the joint fit on the held-out tests.
    identifiable : dict
        Summary of the identifiability analysis (see :meth:`to_json`).
    seconds : float
    """

    data: BenchData
    fits: list[FitResult]
    bounds: dict[str, list[float]]
    joint: FitResult | None
    holdout_files: list[str]
    holdout_errors: list[dict]
    identifiable: dict
    seconds: float = 0.0
    starts: int = 0

    @property
    def success(self) -> bool:
        return any(f.success for f in self.fits)

    def to_json(self) -> dict:
        """The CLI contract: ``{"tests": [...], "bounds": {...}, "identifiable": {...}}``."""
        tests = []
        gen = self.data.has_generator
        for t, f in zip(self.data.tests, self.fits):
            params = {k: v for k, v in f.parameters.items()
                      if gen or k not in _BEARING}
            tests.append({"file": t.file, "frequency_hz": t.frequency_hz, "load_ohm": t.load_ohm,
                          "parameters": params if f.success else None,
                          "delta_F": f.delta_F, "delta_V": f.delta_V,
                          "force_relative_error_percent": f.force_relative_error_percent,
                          "success": f.success, "status": f.status, "message": f.message,
                          "nit": f.nit, "starts": f.starts})
        joint = None
        if self.joint is not None:
            joint = {"success": self.joint.success, "parameters": self.joint.parameters,
                     "train_files": [r["file"] for r in self.joint.per_test],
                     "train": self.joint.per_test, "holdout": self.holdout_errors}
        return _jsonable({"data_dir": str(self.data.path), "rig": self.data.rig_name,
                          "has_generator": gen, "tests": tests, "bounds": self.bounds,
                          "identifiable": self.identifiable, "joint_fit": joint,
                          "seconds": self.seconds})

    def plot(self, out_dir: str | Path) -> list[Path]:
        """Write Figs 8–12, the identifiability picture and the joint fit to ``out_dir``."""
        from .plots import identify as P
        return P.report_figures(self, Path(out_dir))


def _jsonable(obj: Any) -> Any:
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return v if math.isfinite(v) else None
    if isinstance(obj, (np.integer,)):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def _fit_one(args: tuple) -> FitResult:
    test, harvester, has_gen, components, starts, seed, options, fixed = args
    return fit_tests([test], harvester, has_generator=has_gen, components=components,
                     starts=starts, seed=seed, jobs=1, options=options, fixed=fixed)


def _default_holdout(data: BenchData) -> list[str]:
    """Every third test in file order (a spread over frequency and load)."""
    if len(data.tests) < 3:
        return []
    return [t.file for k, t in enumerate(data.tests) if k % 3 == 1]


def identify(data: BenchData | str | Path, *, starts: int = 4, jobs: int = 1, seed: int = 0,
             components: Sequence[Component] = (), holdout: Sequence[str] | None = None,
             progress: Callable[[int], None] | None = None,
             options: IdentifyOptions | None = None, fixed: Mapping[str, Any] | None = None,
             joint: bool = True) -> IdentificationReport:
    """The paper's identification procedure on a data directory.

    Per test: multistart collocation/IPOPT fit (the paper's steps 1–8); per
    parameter: min/max over the tests (Table 2 bounds); identifiability at each
    optimum; a joint fit on the tests not in ``holdout`` and its error on the
    held-out tests.

    Parameters
    ----------
    data : BenchData or path
        Loaded data, or a directory (validated by the strict loader first: bad
        data is refused before any solve).
    starts, jobs, seed : int
    components : sequence of Component
    holdout : sequence of str, optional
        Files held out of the joint fit (default: every third test; none when
        fewer than 3 tests).
    progress : callable, optional
        Called with the number of finished per-test fits.
    options : IdentifyOptions
        Default :meth:`IdentifyOptions.for_rig`.
    fixed : mapping, optional
        Fixed/tied parameters (see :func:`fit_tests`).  For rigs without
        generator the default ties the breakaway to the Coulomb force and fixes
        the breakaway velocity at 1 mm/s, so the law reduces to
        M a + f_v v + F_C tanh(v / 0.1 mm/s) + F_0, the EMPS reference model.
    joint : bool
        Run the joint fit (one parameter set, at most 300 objective samples and
        100 intervals per training test, ``min(starts, 2)`` starts).
    """
    if not isinstance(data, BenchData):
        data = load_bench(data)
    if not (isinstance(starts, int) and starts >= 1):
        raise ValueError(f"identify: starts must be an integer >= 1, got {starts!r}")
    if not (isinstance(jobs, int) and jobs >= 1):
        raise ValueError(f"identify: jobs must be an integer >= 1, got {jobs!r}")
    options = options or IdentifyOptions.for_rig(data.has_generator)
    if fixed is None:
        fixed = {} if data.has_generator else {"nut_breakaway_N": "nut_coulomb_N",
                                               "nut_breakaway_velocity_m_per_s": 1e-3}
    t0 = time.perf_counter()
    args = [(t, data.harvester, data.has_generator, list(components), starts, seed + k,
             options, dict(fixed)) for k, t in enumerate(data.tests)]
    fits: list[FitResult] = []
    if jobs == 1 or len(args) == 1:
        for a in args:
            fits.append(_fit_one(a))
            if progress:
                progress(len(fits))
    else:
        with _pool(jobs) as ex:
            for f in ex.map(_fit_one, args):
                fits.append(f)
                if progress:
                    progress(len(fits))
    good = [f for f in fits if f.success]
    bounds = {}
    if good:
        for n in good[0].varied:
            vals = [f.parameters[n] for f in good]
            bounds[n] = [float(min(vals)), float(max(vals))]
    ident = _summarise_identifiability(data, fits)
    jres, hold_files, hold_err = None, [], []
    if joint and len(data.tests) >= 2:
        hold_files = list(holdout) if holdout is not None else _default_holdout(data)
        unknown = [f for f in hold_files if f not in {t.file for t in data.tests}]
        if unknown:
            raise ValueError(f"identify: holdout file(s) {', '.join(unknown)} not in the data")
        train = [t for t in data.tests if t.file not in hold_files]
        held = [t for t in data.tests if t.file in hold_files]
        if train:
            # the joint NLP holds every training test: fewer objective samples per test
            jopt = dataclasses.replace(options, max_samples=min(options.max_samples, 300),
                                       max_intervals=min(options.max_intervals, 100))
            jres = fit_tests(train, data.harvester, has_generator=data.has_generator,
                             components=components, starts=max(1, min(starts, 2)), seed=seed,
                             jobs=jobs, options=jopt, fixed=fixed, identifiability=False)
            if jres.success and held:
                preds = simulate_tests(held, data.harvester, jres.parameters,
                                       has_generator=data.has_generator, components=components,
                                       options=options)
                hold_err = _test_errors(held, preds)
    return IdentificationReport(data, fits, bounds, jres, hold_files, hold_err, ident,
                                time.perf_counter() - t0, starts)


def _summarise_identifiability(data: BenchData, fits: Sequence[FitResult]) -> dict:
    """Across tests: which directions are weak, spread of raw parameters against the
    spread of the identifiable rod friction, and the rigid-bench voltage finding."""
    good = [(t, f) for t, f in zip(data.tests, fits) if f.success and f.identifiability]
    if not good:
        return {"note": "no successful fit to analyse"}
    weak_counts: dict[str, int] = {}
    for _, f in good:
        seen = set()
        for d in f.identifiability["directions"]:
            if not d["identifiable"]:
                seen.add(" / ".join(sorted(d["main"])))
        for s in seen:
            weak_counts[s] = weak_counts.get(s, 0) + 1
    r = data.harvester.lead_m_per_rad
    spread = {}
    for n in good[0][1].varied:
        vals = np.array([f.parameters[n] for _, f in good])
        spread[n] = float(np.std(vals) / max(abs(np.mean(vals)), 1e-300))
    rod_spread = {}
    if "nut_coulomb_N" in good[0][1].varied:
        for v in (0.02, 0.05, 0.1):
            vals = np.array([float(rod_friction_N(v, [f.parameters[n] for n in FRICTION_NAMES],
                                                  r)) for _, f in good])
            rod_spread[f"{v:g}"] = {"mean_N": float(vals.mean()),
                                    "relative_spread": float(vals.std() / abs(vals.mean()))}
    per_test = [{"file": t.file, "condition_number": f.identifiability["condition_number"],
                 "non_identifiable": f.identifiability["non_identifiable"],
                 "combinations": f.identifiability["combinations"]} for t, f in good]
    voltage_note = None
    if data.has_generator:
        voltage_note = ("On a rigid bench the winding current obeys L di/dt = K_e v/r − R i "
                        "with v prescribed: δ_V does not depend on any friction parameter. "
                        "Where δ_V > δ_F the minimax max(δ_V, δ_F) is flat in the friction; "
                        "the identification minimises t + w·mean(J) so that the force error "
                        "still decides the friction.")
    return {"non_identifiable_directions": weak_counts, "relative_spread_of_parameters": spread,
            "rod_friction_spread_by_velocity_m_per_s": rod_spread, "per_test": per_test,
            "voltage_independent_of_friction": voltage_note}
