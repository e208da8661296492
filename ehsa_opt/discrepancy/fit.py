"""Re-identification for the discrepancy workflow: one parameter set for a group of
tests, generic over the bench model's components, by direct collocation + IPOPT.

The model is the :class:`~ehsa_opt.models.bench.BenchModel` (``generator=False``
for rigs without generator, e.g. EMPS: ``M a + friction(v) + offset``), so any
registered :class:`~ehsa_opt.models.components.Component` plugs in without a copy
of the model.  Without a generator the bearing friction is fixed at zero (it is
indistinguishable from the nut friction at the rod).

Transcription (on each test's own sample grid): the states of every sample are
decision variables; defects use the trapezoidal rule for mechanical states and
backward Euler for the stiff winding current (L/R ≪ the sample step; backward
Euler tracks its slow manifold with the right first-order lag).  The objective is
the Gaussian log-likelihood of force (and voltage) residuals, each channel
scaled by its noise level estimated from the measured signal itself
(:func:`noise_std`).  Parameters are scaled by typical magnitudes; bounds come
from :data:`~ehsa_opt.params.FRICTION_RANGES` (widened) and each component's
``ParamSpec``; IPOPT's return status is checked and reported.

Forward predictions for held-out tests are true simulations (CVODES, one
unrecorded warm-up cycle for sine tests), never collocation.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Any, Mapping, Sequence

import casadi as ca
import numpy as np

from ..bench import simulate_bench
from ..data import BenchTest
from ..identify import force_relative_error_percent
from ..models import BenchModel
from ..models.components import Component, ParamSpec
from ..motion import FilteredMotion, SineMotion
from ..params import FRICTION_NAMES, HarvesterParams

__all__ = ["Rig", "PreparedTest", "FitOutcome", "prepare_tests", "noise_std",
           "fit_group", "predict", "polish", "PolishOutcome", "FilteredMotion", "force_relative_error_percent", "linear_baseline",
           "BASE_SPECS"]

NUT_NAMES = FRICTION_NAMES[:4]

#: Values fixed on a rig without generator: no load, no (separable) bearing friction.
NO_GENERATOR_FIXED: dict[str, float] = {
    "load_ohm": 1.0, "bearing_breakaway_Nm": 0.0, "bearing_coulomb_Nm": 0.0,
    "bearing_breakaway_velocity_rad_per_s": 1.0, "bearing_viscous_Nms_per_rad": 0.0}

#: Bounds and typical scales of the base parameters (bounds wider than the SPEC §2
#: distributor ranges, which are for drawing starts, not limits).
BASE_SPECS: dict[str, ParamSpec] = {
    "nut_breakaway_N": ParamSpec("nut_breakaway_N", "N", 50.0, 0.0, 2000.0),
    "nut_coulomb_N": ParamSpec("nut_coulomb_N", "N", 30.0, 0.0, 2000.0),
    "nut_breakaway_velocity_m_per_s": ParamSpec("nut_breakaway_velocity_m_per_s", "m/s", 0.01,
                                                2e-4, 0.5),
    "nut_viscous_Ns_per_m": ParamSpec("nut_viscous_Ns_per_m", "N s/m", 150.0, 0.0, 1e4),
    "bearing_breakaway_Nm": ParamSpec("bearing_breakaway_Nm", "N m", 0.02, 0.0, 1.0),
    "bearing_coulomb_Nm": ParamSpec("bearing_coulomb_Nm", "N m", 0.015, 0.0, 1.0),
    "bearing_breakaway_velocity_rad_per_s": ParamSpec("bearing_breakaway_velocity_rad_per_s",
                                                      "rad/s", 1.0, 0.01, 50.0),
    "bearing_viscous_Nms_per_rad": ParamSpec("bearing_viscous_Nms_per_rad", "N m s/rad", 3e-5,
                                             0.0, 1e-2),
    "inertia_kg": ParamSpec("inertia_kg", "kg", 50.0, 0.0, 1e4, "moving mass M"),
    "offset_N": ParamSpec("offset_N", "N", 0.0, -1e3, 1e3, "force offset"),
}


def _scale(spec: ParamSpec) -> float:
    if spec.default != 0.0:
        return abs(spec.default)
    return max(abs(spec.lower), abs(spec.upper)) / 20.0 or 1.0


_MODELS: dict[tuple, Any] = {}


@dataclass(frozen=True)
class Rig:
    """What is fitted: harvester constants, rig kind and the model's components."""

    harvester: HarvesterParams
    has_generator: bool = True
    components: tuple[Component, ...] = ()

    def model(self) -> BenchModel:
        """The rig's model (cached: one model object per distinct rig, kept alive —
        :func:`~ehsa_opt.bench.simulate_bench` caches integrators by model identity)."""
        key = (self.has_generator, self.harvester,
               tuple((type(c).__name__, tuple(sorted(vars(c).items()))) for c in self.components))
        if key not in _MODELS:
            _MODELS[key] = BenchModel(self.harvester, self.components,
                                      generator=self.has_generator)
        return _MODELS[key]

    def with_components(self, components: Sequence[Component]) -> "Rig":
        return Rig(self.harvester, self.has_generator, tuple(components))

    @property
    def base_names(self) -> list[str]:
        return list(FRICTION_NAMES) if self.has_generator else ["inertia_kg", "offset_N",
                                                                 *NUT_NAMES]


def noise_std(y: np.ndarray) -> float:
    """Noise level of a sampled signal from its second differences (robust, model-free).

    For white noise of std σ on a smooth signal, Δ²y has std √6 σ; the median
    absolute deviation makes it insensitive to short peaks.
    """
    d2 = np.diff(np.asarray(y, dtype=float), 2)
    mad = np.median(np.abs(d2 - np.median(d2)))
    return float(max(1.4826 * mad / math.sqrt(6.0), 1e-12))


@dataclass
class PreparedTest:
    """A test with its motion on the sample grid (``u`` = x, v, a) and noise levels."""

    test: BenchTest
    motion: Any
    time_s: np.ndarray
    u: np.ndarray
    y: np.ndarray  # (ny, N) measured force [, voltage]
    sigma: np.ndarray  # (ny,)
    fixed: dict[str, float]


def _sine_motion(test: BenchTest) -> SineMotion:
    """The sine of the test's frequency fitted (amplitude, phase) to the measured x."""
    w = 2 * math.pi * float(test.frequency_hz)
    t = test.time_s
    A = np.column_stack([np.sin(w * t), np.cos(w * t)])
    (a, b), *_ = np.linalg.lstsq(A, test.displacement_m, rcond=None)
    return SineMotion(float(math.hypot(a, b)), float(test.frequency_hz), float(math.atan2(b, a)))


def prepare_tests(tests: Sequence[BenchTest], has_generator: bool = True,
                  derivative_cutoff_hz: float | None = None) -> list[PreparedTest]:
    """Motion, measured outputs and noise levels of each test.

    Sine tests: the sine of the test frequency fitted to the measured
    displacement.  Recorded tests: :class:`FilteredMotion` with cut-off
    ``derivative_cutoff_hz`` (default: a tenth of the sample rate).
    """
    out = []
    for t in tests:
        if t.excitation == "sine" and t.frequency_hz:
            motion: Any = _sine_motion(t)
        else:
            fs = 1.0 / float(np.median(np.diff(t.time_s)))
            motion = FilteredMotion(t.time_s, t.displacement_m, derivative_cutoff_hz or fs / 10)
        u = motion.evaluate(t.time_s)
        ys = [t.force_N] + ([t.voltage_V] if has_generator and t.voltage_V is not None else [])
        y = np.vstack(ys)
        sig = np.array([noise_std(row) for row in y])
        fixed = {"load_ohm": float(t.load_ohm)} if has_generator else dict(NO_GENERATOR_FIXED)
        out.append(PreparedTest(t, motion, t.time_s, u, y, sig, fixed))
    return out


# ------------------------------------------------------------------ linear baseline
def linear_baseline(prepared: Sequence[PreparedTest], rig: Rig,
                    breakaway_velocities: Sequence[float] = (0.003, 0.01, 0.03)
                    ) -> dict[str, float]:
    """Quick least-squares friction (rigid, quasi-static current): the force is linear
    in (F_C, F_brk − F_C, f_v[, M, offset]) for a fixed breakaway velocity, tried on
    a small grid.  Used as the IPOPT initial point; bearing friction starts at zero
    (its split from the nut friction is not identifiable on a rigid bench, SPEC §2)."""
    h = rig.harvester
    r = h.lead_m_per_rad
    best: tuple[float, dict[str, float]] | None = None
    for ub in breakaway_velocities:
        rows, rhs = [], []
        for pt in prepared:
            x, v, a = pt.u
            F = pt.y[0]
            ust, uc = math.sqrt(2) * ub, ub / 10
            cols = [np.tanh(v / uc), math.sqrt(2 * math.e) * np.exp(-(v / ust) ** 2) * v / ust, v]
            if rig.has_generator:
                R = pt.fixed["load_ohm"] + h.internal_resistance_ohm
                known = h.equivalent_mass_kg() * a + h.torque_constant_Nm_per_A * \
                    h.voltage_constant_Vs_per_rad * v / (r * r * R)
            else:
                known = 0.0 * v
                cols += [a, np.ones_like(v)]
            w = 1.0 / pt.sigma[0]
            rows.append(np.column_stack(cols) * w)
            rhs.append((F - known) * w)
        A, b = np.vstack(rows), np.concatenate(rhs)
        coef, *_ = np.linalg.lstsq(A, b, rcond=None)
        sse = float(np.sum((A @ coef - b) ** 2))
        Fc, dF, fv = max(coef[0], 0.0), max(coef[1], 0.0), max(coef[2], 0.0)
        vals = {"nut_coulomb_N": Fc, "nut_breakaway_N": Fc + dF,
                "nut_breakaway_velocity_m_per_s": ub, "nut_viscous_Ns_per_m": fv}
        if rig.has_generator:
            vals.update({"bearing_breakaway_Nm": 1e-3, "bearing_coulomb_Nm": 1e-3,
                         "bearing_breakaway_velocity_rad_per_s": 1.0,
                         "bearing_viscous_Nms_per_rad": 1e-6})
        else:
            vals.update({"inertia_kg": float(coef[3]), "offset_N": float(coef[4])})
        if best is None or sse < best[0]:
            best = (sse, vals)
    assert best is not None
    return best[1]


# ------------------------------------------------------------------ the NLP
@dataclass
class FitOutcome:
    """Result of :func:`fit_group` (mirrors ``scipy.optimize.OptimizeResult``).

    Attributes
    ----------
    success : bool
    message : str
        IPOPT return status of the best start.
    parameters : dict[str, float]
        All base and component parameters (fitted and fixed).
    free : list[str]
        The fitted names.
    objective : float
        Mean squared noise-normalised residual on the fitted tests.
    sse : float
        Sum of squared noise-normalised residuals; ``n_obs`` observations.
    n_obs : int
    starts : list[dict]
        Per start: status, objective, iterations.
    seconds : float
    covariance : ndarray or None
        Gauss–Newton covariance of the free parameters (scaled by the residual variance).
    """

    success: bool
    message: str
    parameters: dict[str, float]
    free: list[str]
    objective: float
    sse: float
    n_obs: int
    starts: list[dict] = field(default_factory=list)
    seconds: float = 0.0
    covariance: np.ndarray | None = None

    def interval(self, name: str, z: float = 1.96) -> tuple[float, float] | None:
        """~95 % interval of a fitted parameter (None if not fitted or unavailable)."""
        if self.covariance is None or name not in self.free:
            return None
        k = self.free.index(name)
        sd = math.sqrt(max(float(self.covariance[k, k]), 0.0))
        v = self.parameters[name]
        return (v - z * sd, v + z * sd)


def _fine_grid(t: np.ndarray, M: int) -> np.ndarray:
    """``M`` equal sub-intervals in every sample interval (samples at every M-th node)."""
    if M == 1:
        return t
    frac = np.arange(M) / M
    tf = (t[:-1, None] + np.diff(t)[:, None] * frac[None, :]).ravel()
    return np.append(tf, t[-1])


def _state_map(model: Any, pt: PreparedTest, h: HarvesterParams, u: np.ndarray
               ) -> tuple[np.ndarray, np.ndarray]:
    """Affine map of the decision variables Z to the states: X = offset + diag(s) Z.

    Rotor angle and speed are expressed through the transmission deflection
    δ = x − rθ and its rate (θ = x/r − δ/r, ω = v/r − δ̇/r) — δ is micrometres
    while θ is tens of radians, so this is what keeps a stiff contact well scaled.
    """
    r = h.lead_m_per_rad
    s = _state_scales(model, pt, h)
    off = np.zeros((len(model.state_names), u.shape[1]))
    for k, n in enumerate(model.state_names):
        if n == "rotor_angle_rad":
            s[k] = -1e-4 / r
            off[k] = u[0] / r
        elif n == "rotor_speed_rad_per_s":
            s[k] = -1e-2 / r
            off[k] = u[1] / r
    return s, off


def _state_scales(model: Any, pt: PreparedTest, h: HarvesterParams) -> np.ndarray:
    r = h.lead_m_per_rad
    vmax = float(np.max(np.abs(pt.u[1]))) or 1.0
    xmax = float(np.max(np.abs(pt.u[0]))) or 1.0
    out = []
    for n in model.state_names:
        if n == "current_A":
            out.append(h.voltage_constant_Vs_per_rad * vmax / r
                       / (pt.fixed.get("load_ohm", 1.0) + h.internal_resistance_ohm))
        elif n == "rotor_angle_rad":
            out.append(xmax / r)
        elif n == "rotor_speed_rad_per_s":
            out.append(vmax / r)
        else:
            out.append(1.0)
    return np.array(out)


def fit_group(prepared: Sequence[PreparedTest], rig: Rig, starts: Sequence[Mapping[str, float]],
              *, free: Sequence[str] | None = None, fixed: Mapping[str, float] | None = None,
              max_iter: int = 300, regularisation: float = 1e-6,
              max_cpu_s: float = 60.0, substeps: int | None = None) -> FitOutcome:
    """Fit one parameter set to all ``prepared`` tests (collocation + IPOPT).

    Parameters
    ----------
    prepared : list of PreparedTest
    rig : Rig
    starts : list of dict
        Initial parameter values (missing names: ParamSpec defaults); the best
        converged start is kept.
    free : list of str, optional
        Names to fit (default: all base names and all component parameters).
    fixed : dict, optional
        Values of non-fitted parameters.
    substeps : int, optional
        Collocation sub-intervals per sample interval (default 1: at 1 kHz the
        collocation objective at the true backlash parameters matches the CVODES
        simulation's within 1 %).
    max_cpu_s : float
        IPOPT CPU-time cap per start, s (the point reached is kept and its status
        reported).
    regularisation : float
        Weight of a tiny pull of the scaled parameters toward the start, so
        non-identifiable directions (nut vs bearing friction split) stay put.
    """
    t0 = time.perf_counter()
    model = rig.model()
    M = int(substeps or 1)
    h = rig.harvester
    specs = {**BASE_SPECS, **model.param_specs}
    names = [n for n in model.param_names if n != "load_ohm"]
    free = list(free) if free is not None else rig.base_names + list(model.param_specs)
    fixed = dict(fixed or {})
    if not rig.has_generator:
        fixed = {**NO_GENERATOR_FIXED, **fixed}
    scales = np.array([_scale(specs[n]) for n in free])
    z = ca.MX.sym("z", len(free))
    psym = {n: z[k] * scales[k] for k, n in enumerate(free)}

    def default_of(n: str) -> float:
        return float(fixed.get(n, specs[n].default))

    wparts, w_lb, w_ub, gparts = [z], [], [], []
    lbz = np.array([specs[n].lower for n in free]) / scales
    ubz = np.array([specs[n].upper for n in free]) / scales
    w_lb.append(lbz)
    w_ub.append(ubz)
    J = 0
    n_obs = 0
    rparts: list[Any] = []
    indep = list(range(len(free)))
    state_scales: list[np.ndarray] = []
    for k, pt in enumerate(prepared):
        N = pt.time_s.size
        pvec = []
        for n in model.param_names:
            if n in pt.fixed:
                pvec.append(ca.MX(pt.fixed[n]))
            elif n in psym:
                pvec.append(psym[n])
            else:
                pvec.append(ca.MX(default_of(n)))
        p = ca.vertcat(*pvec)
        nx = model.n_states
        tf = _fine_grid(pt.time_s, M) if nx else pt.time_s
        Nf = tf.size
        P = ca.repmat(p, 1, Nf)
        uf = pt.motion.evaluate(tf) if M > 1 and nx else pt.u
        U = ca.DM(uf)
        if nx:
            sx, x_off = _state_map(model, pt, h, uf)
            Xs = ca.MX.sym(f"X{k}", nx, Nf)
            X = ca.DM(x_off) + ca.diag(ca.DM(sx)) @ Xs
            offset = sum(int(wp.numel()) for wp in wparts)
            indep += list(range(offset, offset + nx))  # initial states are free
            wparts.append(ca.vec(Xs))
            w_lb.append(np.full(nx * Nf, -np.inf))
            w_ub.append(np.full(nx * Nf, np.inf))
            f = model.ode.map(Nf)(X, U, P)
            dt = ca.DM(np.diff(tf)).T
            wbe = np.array([1.0 if n == "current_A" else 0.5 for n in model.state_names])
            Wbe, Wtr = ca.DM(np.tile(wbe[:, None], (1, Nf - 1))), \
                ca.DM(np.tile(1 - wbe[:, None], (1, Nf - 1)))
            incr = (Wbe * f[:, 1:] + Wtr * f[:, :-1]) * ca.repmat(dt, nx, 1)
            defect = X[:, 1:] - X[:, :-1] - incr
            gparts.append(ca.vec(ca.diag(ca.DM(1 / sx)) @ defect))
            Y = model.outputs.map(N)(X[:, ::M], U[:, ::M], P[:, ::M])
            state_scales.append((sx, x_off, tf))
        else:
            Y = model.outputs.map(N)(ca.MX(0, N), U, P)
        ny = pt.y.shape[0]
        R = (Y[:ny, :] - ca.DM(pt.y)) / ca.repmat(ca.DM(pt.sigma), 1, N)
        rparts.append(ca.vec(R))
        J += ca.sumsqr(R)
        n_obs += ny * N
    z0s = []
    for st in starts:
        vals = {n: float(st.get(n, fixed.get(n, specs[n].default))) for n in free}
        z0s.append(np.clip(np.array([vals[n] for n in free]) / scales, lbz, ubz))
    zref = ca.DM(z0s[0])
    obj = J / n_obs + regularisation * ca.sumsqr(z - zref)
    # friction order constraints: breakaway >= Coulomb
    g_lb, g_ub = [], []
    for a, b in (("nut_breakaway_N", "nut_coulomb_N"), ("bearing_breakaway_Nm",
                                                         "bearing_coulomb_Nm")):
        if a in psym or b in psym:
            va = psym.get(a, ca.MX(default_of(a)))
            vb = psym.get(b, ca.MX(default_of(b)))
            gparts.append((va - vb) / _scale(specs[a]))
    ng_dyn = sum(int(gp.numel()) for gp in gparts)
    n_order = sum(1 for a, b in (("nut_breakaway_N", "nut_coulomb_N"),
                                 ("bearing_breakaway_Nm", "bearing_coulomb_Nm"))
                  if a in psym or b in psym)
    g = ca.vertcat(*gparts) if gparts else ca.MX(0, 1)
    g_lb = np.concatenate([np.zeros(ng_dyn - n_order), np.zeros(n_order)])
    g_ub = np.concatenate([np.zeros(ng_dyn - n_order), np.full(n_order, np.inf)])
    w = ca.vertcat(*wparts)
    opts = {"ipopt.print_level": 0, "print_time": False, "ipopt.max_iter": max_iter,
            "ipopt.tol": 1e-8, "ipopt.acceptable_tol": 1e-5, "ipopt.mu_strategy": "adaptive",
            "ipopt.max_cpu_time": max_cpu_s}
    solver = ca.nlpsol("discrepancy_fit", "ipopt", {"x": w, "f": obj, "g": g}, opts)
    lbw, ubw = np.concatenate(w_lb), np.concatenate(w_ub)
    best = None
    records = []
    for z0 in z0s:
        # states initialised by a forward simulation with the start's parameters, so
        # the collocation starts (nearly) feasible — important for stiff contacts
        pstart = {n: default_of(n) for n in names}
        pstart.update({n: float(z0[k] * scales[k]) for k, n in enumerate(free)})
        state_init = []
        if model.n_states:
            for pt, (sx, x_off, tf) in zip(prepared, state_scales):
                X0 = _simulate(model, pt, pstart, tf).states
                state_init.append(((X0 - x_off) / sx[:, None]).ravel(order="F"))
        x0 = np.concatenate([z0, *state_init])
        sol = solver(x0=x0, lbx=lbw, ubx=ubw, lbg=g_lb, ubg=g_ub)
        st = solver.stats()
        f = float(sol["f"])
        records.append({"status": st["return_status"], "success": bool(st["success"]),
                        "objective": f, "iterations": int(st.get("iter_count", -1))})
        # an iteration/time cap still leaves a usable (improved, feasible) point
        ok = st["success"] or st["return_status"] in ("Solved_To_Acceptable_Level",
                                                       "Maximum_Iterations_Exceeded",
                                                       "Maximum_CpuTime_Exceeded")
        if ok and np.isfinite(f) and (best is None or f < best[0]):
            best = (f, np.array(sol["x"]).ravel(), st)
    if best is None:
        return FitOutcome(False, "; ".join(r["status"] for r in records), {}, free, math.inf,
                          math.inf, n_obs, records, time.perf_counter() - t0)
    f, xopt, st = best
    zopt = xopt[:len(free)]
    params = {n: default_of(n) for n in names}
    params.update({n: float(zopt[k] * scales[k]) for k, n in enumerate(free)})
    sse = float(ca.Function("J", [w], [J])(xopt))
    cov = _covariance(ca.vertcat(*rparts), w, g, xopt, indep, len(free), scales,
                      sse / max(n_obs - len(free), 1), ng_dyn - n_order)
    return FitOutcome(bool(st["success"]), st["return_status"], params, free, sse / n_obs, sse,
                      n_obs, records, time.perf_counter() - t0, cov)


def _sparse(m: Any) -> Any:
    import scipy.sparse as sp
    m = ca.DM(m)
    r, c = m.sparsity().get_triplet()
    return sp.csc_matrix((np.array(m.nonzeros()), (r, c)), shape=m.shape)


def _covariance(Rvec: Any, w: Any, g: Any, xopt: np.ndarray, indep: list[int], nz: int,
                scales: np.ndarray, s2: float, n_eq: int) -> np.ndarray | None:
    """Gauss–Newton covariance of the free parameters: the states are eliminated
    through the collocation constraints (dX/dz = −A_x⁻¹ A_z), then
    cov = s² (SᵀS)⁺ with S = dR/dz the total sensitivity of the normalised residuals
    (initial states are nuisance parameters, marginalised)."""
    import scipy.sparse.linalg as spla
    try:
        Jr = _sparse(ca.Function("Jr", [w], [ca.jacobian(Rvec, w)])(xopt))
        ind = np.array(indep)
        dep = np.setdiff1d(np.arange(Jr.shape[1]), ind)
        if n_eq:
            A = _sparse(ca.Function("A", [w], [ca.jacobian(g[:n_eq], w)])(xopt))
            Ax, Az = A[:, dep].tocsc(), A[:, ind].toarray()
            dX = -spla.splu(Ax).solve(Az)
            S = Jr[:, ind].toarray() + Jr[:, dep] @ dX
        else:
            S = Jr[:, ind].toarray()
        cov_z = np.linalg.pinv(S.T @ S)[:nz, :nz] * s2
        return cov_z * np.outer(scales, scales)
    except Exception as exc:  # noqa: BLE001 - intervals are a report extra, never fatal
        import warnings
        warnings.warn(f"parameter covariance unavailable: {exc}")
        return None


# ------------------------------------------------------------------ predictions
def predict(prepared: Sequence[PreparedTest], rig: Rig, parameters: Mapping[str, float]
            ) -> list[np.ndarray]:
    """Simulated outputs (ny, N) of each test with the given parameters.

    Models with states are integrated by CVODES from rest-consistent initial
    states, one unrecorded warm-up cycle before the record for sine tests.
    """
    model = rig.model()
    out = []
    for pt in prepared:
        vals = {**pt.fixed, **parameters}
        p = np.array([float(vals[n]) for n in model.param_names])
        ny = pt.y.shape[0]
        if model.n_states == 0:  # algebraic model: evaluate on the samples
            y = np.array(model.outputs.map(pt.time_s.size)(np.zeros((0, pt.time_s.size)),
                                                          pt.u, p))
            out.append(y[:ny])
            continue
        sim = _simulate(model, pt, vals)
        out.append(np.vstack([sim.force_N, sim.voltage_V])[:ny])
    return out


@dataclass
class PolishOutcome:
    """Result of :func:`polish` (mirrors ``scipy.optimize.OptimizeResult``).

    Attributes
    ----------
    success : bool
        The simulated SSE did not increase (always true of the returned point).
    message : str
    parameters : dict[str, float]
    sse_before, sse_after : float
        Sum of squared noise-normalised simulation residuals on the fitted tests.
    nfev : int
        Simulations of the test group (including finite differences).
    seconds : float
    """

    success: bool
    message: str
    parameters: dict[str, float]
    sse_before: float
    sse_after: float
    nfev: int
    seconds: float


def polish(prepared: Sequence[PreparedTest], rig: Rig, parameters: Mapping[str, float],
           free: Sequence[str], *, max_iter: int = 8, diff_step: float = 1e-3) -> PolishOutcome:
    """Refine a collocation fit on the forward simulation itself.

    The collocation defects are a one-step rule on the sample grid; a stiff
    transmission (e.g. a 5e7 N/m compliance on the 47.5 kg rotor-equivalent mass:
    165 Hz against 1 kHz sampling) makes its optimum differ from what CVODES
    simulates with the same parameters.  A few trust-region Gauss–Newton steps
    (``scipy.optimize.least_squares``, method ``trf``) on the noise-normalised
    residuals of :func:`predict`, with forward-difference sensitivities in the
    scaled parameters and the fit bounds, close that gap.

    Parameters
    ----------
    prepared : list of PreparedTest
    rig : Rig
    parameters : dict
        Start (all model parameters, e.g. ``FitOutcome.parameters``).
    free : list of str
        Names refined (the rest stay fixed).
    max_iter : int
        Gauss–Newton iterations (each costs ``len(free) + 1`` simulations of the group).
    diff_step : float
        Forward-difference step in the scaled parameters.
    """
    from scipy.optimize import least_squares
    t0 = time.perf_counter()
    model = rig.model()
    specs = {**BASE_SPECS, **model.param_specs}
    free = list(free)
    scales = np.array([_scale(specs[n]) for n in free])
    lb = np.array([specs[n].lower for n in free]) / scales
    ub = np.array([specs[n].upper for n in free]) / scales
    base = dict(parameters)
    counter = [0]

    def resid(z: np.ndarray) -> np.ndarray:
        counter[0] += 1
        vals = {**base, **{n: float(z[k] * scales[k]) for k, n in enumerate(free)}}
        preds = predict(prepared, rig, vals)
        r = np.concatenate([((pt.y - yp) / pt.sigma[:, None]).ravel()
                            for pt, yp in zip(prepared, preds)])
        return np.nan_to_num(r, nan=1e6, posinf=1e6, neginf=-1e6)

    z0 = np.clip(np.array([base[n] for n in free]) / scales, lb, ub)
    r0 = resid(z0)
    sse0 = float(r0 @ r0)
    try:
        sol = least_squares(resid, z0, bounds=(lb, ub), method="trf", x_scale="jac",
                            diff_step=diff_step, max_nfev=max_iter, jac="2-point")
    except Exception as exc:  # noqa: BLE001 - a failed polish keeps the collocation fit
        return PolishOutcome(False, f"polish failed: {exc}", base, sse0, sse0, counter[0],
                             time.perf_counter() - t0)
    sse1 = float(2.0 * sol.cost)
    if not sse1 < sse0:
        return PolishOutcome(True, "no improvement", base, sse0, sse0, counter[0],
                             time.perf_counter() - t0)
    out = {**base, **{n: float(sol.x[k] * scales[k]) for k, n in enumerate(free)}}
    return PolishOutcome(True, sol.message, out, sse0, sse1, counter[0],
                         time.perf_counter() - t0)


@dataclass
class _Sim:
    force_N: np.ndarray
    voltage_V: np.ndarray
    states: np.ndarray


def _simulate(model: BenchModel, pt: PreparedTest, values: Mapping[str, float],
              grid: np.ndarray | None = None) -> _Sim:
    """CVODES simulation on the test's grid (or ``grid``; one warm-up cycle before
    sine records)."""
    vals = {**pt.fixed, **values}
    p = np.array([float(vals[n]) for n in model.param_names])
    t = pt.time_s if grid is None else grid
    if isinstance(pt.motion, SineMotion):
        period = 1.0 / pt.motion.frequency_hz
        dt = float(np.median(np.diff(t)))
        nw = int(round(period / dt))
        grid = np.concatenate([t[0] - dt * np.arange(nw, 0, -1), t])
        sim = simulate_bench(model, pt.motion, p, grid, rtol=1e-7, atol=1e-9)
        keep = slice(nw, None)
    else:
        motion = pt.motion.sampled() if isinstance(pt.motion, FilteredMotion) else pt.motion
        sim = simulate_bench(model, motion, p, t, rtol=1e-7, atol=1e-9)
        keep = slice(None)
    return _Sim(sim.force_N[keep], sim.voltage_V[keep], sim.states[:, keep])
