"""The library of candidate effects and their residual signatures.

A candidate is a registered :class:`~ehsa_opt.physics.components.Component`
(``COMPONENTS``) plus what the workflow needs to test it: *probe* parameter sets
whose simulated output changes (Δy = y(baseline + effect at probe) − y(baseline))
are the candidate's signature, and *starts* for its re-identification.

Ranking (a score test, linearised): the baseline's normalised residual r is
projected onto the signature columns after removing what a refit of the
baseline friction would absorb anyway (the columns tanh(v/u_c), Stribeck(v), v
of the force, plus a and 1 on a rig without generator).  The score is the share
of the residual energy the signature explains, ‖P r‖²/‖r‖²; the χ² statistic
‖P r‖² (≈ number of columns for pure noise) is reported beside it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ....physics import COMPONENTS, make_component
from ..prepared import PreparedTest
from ..rig import Rig, predict
from ..localise import best_rotor_period, stroke_window
from ..impact_features import impact_energy_ratio
from ..impacts import IMPACT_ENERGY_RATIO
from ..bounds import at_bound
from ..criterion import DEFAULT_POLICY

__all__ = ["Candidate", "CANDIDATES", "candidate_names", "signature_scores", "components_for",
           "absorbed_columns", "compatible", "rank_value", "nnls_weights", "channel_parts",
           "CHANNEL_EXCESS_MIN", "ROTOR_WORSE_SHARE", "MIN_RANK_VALUE", "edge_dominated"]


@dataclass(frozen=True)
class Candidate:
    """A candidate effect: its component name, signature probes and fit starts.

    Attributes
    ----------
    name : str
        Registered component name.
    probes : tuple of dict
        Parameter sets whose output change is a signature column each.
    starts : tuple of dict
        Candidate initial values of the effect parameters for re-identification
        (combined with the baseline friction); they are screened by forward
        simulation and IPOPT starts from the best (nonconvex effects such as a
        gap need a start near the right magnitude).
    needs_generator : bool
        Only testable on rigs that measure the generator (voltage, rotor).
    shares : tuple of float
        Bearing shares of the baseline's lumped friction each start is screened at
        (a gap decides how far the rotor coasts by the friction on the rotor side).
    refine : tuple of dict
        Overrides tried on the best screened start (e.g. the contact stiffness over
        its decades).
    full_refit : str
        How the full refit (friction and effect) is done: ``"collocation"`` (IPOPT)
        or ``"simulation"`` (Gauss–Newton on the forward simulation from the
        effect-only collocation fit; see :func:`~ehsa_opt.estimation.discrepancy.candidate_fit.fit_candidate`).
    effect_fit : str
        How the effect-only stage is done: ``"collocation"`` (IPOPT) or
        ``"simulation"`` (Gauss–Newton on the forward simulation from the screened
        start).
    log_names : tuple of str
        Effect parameters refined in log10 on the simulation (they span decades).
    rigid_channels : tuple of int or None
        Output channels (0 force, 1 voltage) the effect can change on a rig without
        a transmission effect (the rotor then turns with the imposed motion):
        a mechanical effect on the rod or rotor side changes only the force.  The SSE
        alternative of the decision rule is judged on these channels only — a gain
        elsewhere is the current model's re-fit, not the effect.  None: all.
    own_channels : tuple of int or None
        Output channels the effect is seen in beyond what the force law absorbs: a
        generator effect (a voltage drop, a winding's heating, a flux saturation)
        changes the force only through the current, which the baseline's friction and
        damping largely absorb, while the voltage shows it directly.  Such a member
        earns on these channels whatever the force's excess
        (:func:`~ehsa_opt.estimation.discrepancy.judge.earns_on_own_channel`), the
        force kept.  None: the force decides where its excess dominates.
    amplitudes : tuple of str
        Effect parameters that are all zero when the effect is absent (its size):
        the effect earns only when the ~95 % interval of one of them excludes zero
        (:func:`~ehsa_opt.estimation.discrepancy.evidence.significant`).  Empty for a transmission effect, whose
        absence is a limit (infinite stiffness), not a zero.
    limits : tuple of (str, str)
        Bounds of the effect parameters that are physical limits, as (name, "lower" or
        "upper"): a fit there is physical (a stiffness at its upper bound is the rigid
        limit).  Every other nonzero bound is the edge of the member's physical range,
        and a fit there does not earn (:func:`~ehsa_opt.estimation.discrepancy.evidence.at_bound`).
    family_probes : bool
        The probes are points of a family the member moves along (a gap, a mount
        stiffness over its decades), not independent directions (a cogging's sine and
        cosine): the ranking combines them with non-negative weights only
        (:func:`signature_scores`) — the member at some parameter between two probes,
        never the difference of two members, which can mimic any shape.
    impact_fit : bool
        A contact whose impacts the sample-wise fit cannot follow when stiff: when the
        data's transient energy far exceeds the current model's, it is fitted on
        transient energies and kinematic gaps (:mod:`..impacts`).
    simulation_starts : tuple of dict
        Starts added to the screen when a collocation member is fitted by the
        simulation recipe on a large campaign
        (:func:`~ehsa_opt.estimation.discrepancy.candidate_fit.simulation_recipe`):
        Gauss–Newton has no collocation NLP to start near, so a member whose
        parameters are multimodal (a cogging's phase) gets a grid of them.
    nests : tuple of str
        Simpler members this one contains at a limit of its parameters (a backlash
        with no gap is a compliance: the same series spring and damper).  When this
        member earns, those are re-identified in the same round too, whatever their
        rank, so that the choice between them
        (:func:`~ehsa_opt.estimation.discrepancy.judge.choose_winner`) is made on
        fits, not on a linearised signature.
    """

    name: str
    probes: tuple[dict, ...]
    starts: tuple[dict, ...]
    needs_generator: bool = False
    shares: tuple[float, ...] = (0.0,)
    refine: tuple[dict, ...] = ()
    full_refit: str = "collocation"
    effect_fit: str = "collocation"
    log_names: tuple[str, ...] = ()
    amplitudes: tuple[str, ...] = ()
    rigid_channels: tuple[int, ...] | None = None
    own_channels: tuple[int, ...] | None = None
    without_generator_only: bool = False
    impact_fit: bool = False
    limits: tuple[tuple[str, str], ...] = ()
    family_probes: bool = False
    simulation_starts: tuple[dict, ...] = ()
    nests: tuple[str, ...] = ()

    def applicable(self, rig: Rig) -> bool:
        if self.without_generator_only and rig.has_generator:
            return False  # a generator bench has its own elastic transmission (compliance)
        return rig.has_generator or not self.needs_generator

    def component(self, **kwargs):
        return make_component(self.name, **kwargs)


#: The candidate library (every name is a registered component).
CANDIDATES: dict[str, Candidate] = {
    "backlash": Candidate(
        "backlash",
        # one probe per ~half decade of the realistic gaps: the signature is far from
        # linear in the gap, and a 0.8 mm gap projects on neither 0.05 nor 0.2 mm
        probes=({"backlash_gap_m": 5e-5}, {"backlash_gap_m": 2e-4}, {"backlash_gap_m": 1e-3}),
        # gaps over the realistic 0.005-2 mm and below (1.6x apart) at a mid stiffness,
        # each at four rotor-side friction shares; then the stiffness decades 1e4-1e9
        starts=tuple({"backlash_gap_m": float(g), "backlash_contact_stiffness_N_per_m": 5e6}
                     for g in np.geomspace(5e-6, 2e-3, 14)),
        needs_generator=True,
        shares=(0.0, 0.15, 0.3, 0.45),
        refine=tuple({"backlash_contact_stiffness_N_per_m": float(k)}
                     for k in (1e4, 1e5, 1e6, 1e7, 1e8, 1e9)),
        # both stages on the simulation: the effect-only collocation NLP took 225 s per
        # solve on the default data's 6 fit tests (4 tests: 5 s) - IPOPT on a stiff
        # contact's defects; Gauss-Newton from the screened start costs seconds
        effect_fit="simulation", full_refit="simulation",
        log_names=("backlash_contact_stiffness_N_per_m",), impact_fit=True,
        family_probes=True, nests=("compliance",),
        # the rigid contact (at least this stiff) and the contact without rebound
        limits=(("backlash_contact_stiffness_N_per_m", "upper"),
                ("backlash_contact_damping_Ns_per_m", "upper"))),
    "asymmetric_friction": Candidate(
        "asymmetric_friction",
        probes=({"asym_coulomb_N": 5.0}, {"asym_viscous_Ns_per_m": 30.0}),
        starts=({"asym_coulomb_N": 0.5, "asym_viscous_Ns_per_m": 1.0},
                {"asym_coulomb_N": -0.5, "asym_viscous_Ns_per_m": -1.0}),
        amplitudes=("asym_coulomb_N", "asym_viscous_Ns_per_m"),
        rigid_channels=(0,)),
    "cogging": Candidate(
        "cogging",
        probes=({"cogging_sin_Nm": 0.005}, {"cogging_cos_Nm": 0.005}),
        starts=({"cogging_sin_Nm": 1e-3, "cogging_cos_Nm": 1e-3},
                {"cogging_sin_Nm": 2e-2, "cogging_cos_Nm": -2e-2}),
        # the phase on a grid of 45 degrees at two amplitudes when fitted by
        # Gauss-Newton on the simulation (no collocation NLP to start near)
        simulation_starts=tuple({"cogging_sin_Nm": a * math.cos(ph),
                                 "cogging_cos_Nm": a * math.sin(ph)}
                                for a in (0.005, 0.03) for ph in np.arange(8) * math.pi / 4),
        amplitudes=("cogging_sin_Nm", "cogging_cos_Nm"),
        rigid_channels=(0,)),
    "compliance": Candidate(
        "compliance",
        # one probe per decade of the realistic mount stiffness 1e4-1e8 N/m (1e9 is
        # rigid at these rates): like a gap, the signature is far from linear in it
        probes=tuple({"compliance_stiffness_N_per_m": k, "compliance_damping_Ns_per_m": 1e3}
                     for k in (1e4, 1e5, 1e6, 1e7, 1e8)),
        starts=tuple({"compliance_stiffness_N_per_m": k, "compliance_damping_Ns_per_m": c}
                     for k in np.geomspace(1e4, 1e9, 11) for c in (3e2, 3e3)),
        needs_generator=True,
        # on the simulation: on data it does not describe (e.g. a wide gap) the
        # effect-only collocation NLP of a compliance is degenerate and ran for > 20 min
        effect_fit="simulation", full_refit="simulation",
        log_names=("compliance_stiffness_N_per_m",), family_probes=True,
        limits=(("compliance_stiffness_N_per_m", "upper"),)),
    "voltage_drop": Candidate(
        "voltage_drop",
        probes=({"voltage_drop_V": 0.5},),
        starts=tuple({"voltage_drop_V": v} for v in (0.05, 0.2, 0.5, 1.0, 2.0, 3.0)),
        needs_generator=True, amplitudes=("voltage_drop_V",), own_channels=(1,)),
    "winding_heating": Candidate(
        "winding_heating",
        probes=({"winding_heating_K_per_J": 1.0, "winding_cooling_time_s": 100.0},
                {"winding_heating_K_per_J": 1.0, "winding_cooling_time_s": 0.3}),
        starts=tuple({"winding_heating_K_per_J": h, "winding_cooling_time_s": tau}
                     for h in (0.3, 1.0, 3.0, 10.0) for tau in (0.5, 5.0, 50.0)),
        needs_generator=True, amplitudes=("winding_heating_K_per_J",), own_channels=(1,)),
    "position_friction": Candidate(
        "position_friction",
        # centre and width are not in the probes or starts: they come from the
        # component's defaults, which components_for sets from where the force
        # residual behaves like friction on the stroke (localise.stroke_window)
        probes=({"position_friction_N": 10.0},),
        starts=tuple({"position_friction_N": a} for a in (-5.0, 2.0, 8.0, 30.0)),
        amplitudes=("position_friction_N",),
        rigid_channels=(0,)),
    "flexibility": Candidate(
        "flexibility",
        # the resonance starts at the fit residual's spectral peak (components_for);
        # the probes and starts add the load mass and a few frequencies around it
        probes=({"flex_load_mass_kg": 10.0, "flex_damping_ratio": 0.1},
                {"flex_load_mass_kg": 10.0, "flex_damping_ratio": 0.5}),
        starts=tuple({"flex_load_mass_kg": m, "flex_damping_ratio": z}
                     for m in (2.0, 10.0, 30.0) for z in (0.05, 0.3)),
        refine=tuple({"flex_frequency_hz": f} for f in (20.0, 50.0, 115.0, 200.0, 400.0)),
        effect_fit="simulation", full_refit="simulation",
        log_names=("flex_frequency_hz",),
        amplitudes=("flex_load_mass_kg",), rigid_channels=(0,),
        without_generator_only=True),
    "magnetic_saturation": Candidate(
        "magnetic_saturation",
        probes=({"saturation_per_A2": 0.05},),
        starts=tuple({"saturation_per_A2": b} for b in (0.003, 0.01, 0.03, 0.1, 0.3)),
        needs_generator=True, amplitudes=("saturation_per_A2",), own_channels=(1,)),
}
assert set(CANDIDATES) <= set(COMPONENTS)


def candidate_names() -> list[str]:
    """Names of the candidate library, in ranking-table order."""
    return list(CANDIDATES)


def absorbed_columns(pt: PreparedTest, rig: Rig, u_brk: float) -> np.ndarray:
    """Columns (stacked channels) a baseline refit absorbs, normalised by σ."""
    x, v, a = pt.u
    N = v.size
    ust, uc = math.sqrt(2) * u_brk, u_brk / 10
    cols = [np.tanh(v / uc), np.exp(-(v / ust) ** 2) * v / ust, v]
    if not rig.has_generator:
        cols += [a, np.ones(N)]
    # through the measurement's parallel low-pass, as the model's output (a rig
    # without generator; unchanged otherwise)
    F = pt.filter_output(np.column_stack(cols), axis=0) * pt.wnorm[0][:, None]
    ny = pt.y.shape[0]
    return np.vstack([F] + [np.zeros_like(F)] * (ny - 1))


def signature_scores(prepared: Sequence[PreparedTest], rig: Rig, baseline: dict[str, float],
                     baseline_pred: Sequence[np.ndarray], names: Sequence[str] | None = None,
                     components: dict | None = None) -> dict[str, dict]:
    """Score each candidate's signature against the baseline residual.

    ``rig`` may already hold effects (a later round of the workflow): the
    candidate is added to them.  ``components`` maps a name to the component
    instance to use (e.g. a cogging with the period found in the residual).

    Returns
    -------
    dict name → {"score", "chi2", "columns", "applicable"}; inapplicable
    candidates (e.g. voltage_drop on a rig without generator) get score NaN.
    """
    names = list(names or CANDIDATES)
    r = np.concatenate([((pt.y - yp) * pt.wnorm).ravel() for pt, yp in
                        zip(prepared, baseline_pred)])
    # the output channel of each element of the stacked vectors
    chan = np.concatenate([np.repeat(np.arange(pt.y.shape[0]), pt.y.shape[1])
                           for pt in prepared])
    n_ch = int(chan.max()) + 1 if chan.size else 1
    u_brk = float(baseline.get("nut_breakaway_velocity_m_per_s", 0.01))
    B = np.vstack([absorbed_columns(pt, rig, u_brk) for pt in prepared])
    Qb, _ = np.linalg.qr(B)
    r_perp = r - Qb @ (Qb.T @ r)
    total = float(r_perp @ r_perp)
    # impacts the current model has not (a rattling contact): no sample-wise linear
    # signature describes them, the transient energies do
    impacts = impact_energy_ratio(prepared, baseline_pred)
    out: dict[str, dict] = {}
    for name in names:
        cand = CANDIDATES[name]
        comp = (components or {}).get(name) or cand.component()
        taken = {c.name for c in rig.components}
        clash = name in taken or (comp.transmission and any(c.transmission
                                                            for c in rig.components))
        if not cand.applicable(rig) or clash:
            out[name] = {"score": math.nan, "chi2": math.nan, "columns": 0, "applicable": False}
            continue
        crig = rig.with_components([*rig.components, comp])
        spec_defaults = {q.name: q.default for q in crig.model().param_specs.values()}
        spec_defaults.update(comp.defaults())  # e.g. a stroke window set from the data
        cols = []
        for probe in cand.probes:
            vals = {**spec_defaults, **baseline, **probe}
            pred = predict(prepared, crig, vals)
            cols.append(np.concatenate([((yp - yb) * pt.wnorm).ravel() for pt, yp, yb
                                        in zip(prepared, pred, baseline_pred)]))
        S = np.column_stack(cols)
        S = S - Qb @ (Qb.T @ S)
        Qs, Rs = np.linalg.qr(S)
        keep = np.abs(np.diag(Rs)) > 1e-9 * max(np.abs(np.diag(Rs)).max(), 1e-300)
        Qs = Qs[:, keep]
        edge = False
        if cand.family_probes:  # the member somewhere along its family: weights >= 0
            w = nnls_weights(S, r_perp)
            fitted = S @ w
            edge = edge_dominated(w * np.linalg.norm(S, axis=0), [
                bool(at_bound(p, comp.parameters, cand.limits)) for p in cand.probes])
        else:
            fitted = Qs @ (Qs.T @ r_perp)
        proj = float(fitted @ fitted)
        out[name] = {"score": proj / total if total > 0 else 0.0, "chi2": proj,
                     "columns": int(keep.sum()), "applicable": True,
                     "transmission": bool(comp.transmission), "at_bound": edge,
                     "impacts": (impacts if cand.impact_fit and impacts > IMPACT_ENERGY_RATIO
                                 else None),
                     **channel_parts(r_perp, fitted, S, chan, n_ch)}
    return out


def edge_dominated(contributions: np.ndarray, at_edge: Sequence[bool]) -> bool:
    """Whether more than half of a probe family's fitted signature (``contributions``,
    weight × column norm per probe) comes from probes on a non-physical edge of the
    member's range (``at_edge``): the member would be fitted at its bound."""
    c = np.abs(np.asarray(contributions, float))
    edge = np.asarray(at_edge, bool)
    return bool(c.sum() > 0 and c[edge].sum() > 0.5 * c.sum())


def nnls_weights(S: np.ndarray, r: np.ndarray) -> np.ndarray:
    """Non-negative least-squares weights of the columns ``S`` for ``r`` (columns scaled
    to unit norm for the solver, weights returned in the columns' own scale)."""
    from scipy.optimize import nnls
    norm = np.linalg.norm(S, axis=0)
    ok = norm > 0
    w = np.zeros(S.shape[1])
    if ok.any():
        w[ok] = nnls(S[:, ok] / norm[ok], r)[0] / norm[ok]
    return w


def channel_parts(r: np.ndarray, fitted: np.ndarray, S: np.ndarray, chan: np.ndarray,
                  n_ch: int) -> dict:
    """Per output channel (0 force, 1 voltage) of the stacked, noise-normalised vectors:
    the candidate's own channel (where its signature columns ``S`` carry most energy:
    the channel that sees it best) and the share of each channel's residual ``r`` that
    the candidate's fitted signature ``fitted`` explains, 1 − ‖r_c − f_c‖²/‖r_c‖²."""
    energy = [float(np.sum(S[chan == c] ** 2)) for c in range(n_ch)]
    shares = []
    for c in range(n_ch):
        rc, fc = r[chan == c], fitted[chan == c]
        rr = float(rc @ rc)
        shares.append(1.0 - float((rc - fc) @ (rc - fc)) / rr if rr > 0 else 0.0)
    excess = []
    for c in range(n_ch):
        rc = r[chan == c]
        excess.append(float(rc @ rc) / rc.size - 1.0 if rc.size else 0.0)
    return {"channel": int(np.argmax(energy)) if any(energy) else 0,
            "channel_shares": shares, "channel_excess": excess}


#: A channel other than the force ranks a candidate by the share of its residual the
#: candidate explains when its residual exceeds the noise expectation by this share
#: (SSE/N − 1; the decision rule's all-channel alternative uses the same threshold).
CHANNEL_EXCESS_MIN = DEFAULT_POLICY.channel_excess_min


#: A member whose :func:`rank_value` is below this is not re-identified: its signature
#: explains under 2 % of the residual energy of the channel it is ranked on, i.e. it
#: would remove about 1 % of the error's excess — a tenth of what it must remove to
#: earn (the decision rule's 10 %).
MIN_RANK_VALUE = DEFAULT_POLICY.min_rank_value


#: A transmission member whose fitted signature makes the voltage residual's energy grow
#: by more than this share is ranked behind every other member (:func:`rank_value`).
ROTOR_WORSE_SHARE = DEFAULT_POLICY.rotor_worse_share


def rank_value(sc: dict) -> float:
    """The value a candidate is ranked by: its score (share of the stacked residual
    its signature explains), or — for a member seen best on another channel than the
    force (its ``channel``, e.g. a diode drop, a flux saturation or a winding heating
    on the voltage) where that channel's residual has a real excess — the share of
    that channel's residual it explains, when larger.

    The stacked residual is dominated by the force whenever the force carries a misfit
    (the friction law's presliding, which no member describes): a diode drop that
    explains 90 % of the voltage residual then scored below a mount compliance that
    explained 20 % of the force's, and was not fitted before the time budget.  An
    effect is ranked on the channel that sees it.

    A transmission member (a gap, a mount spring) whose fitted signature explains the
    force by making the voltage — the rotor's speed — worse by more than
    :data:`ROTOR_WORSE_SHARE` of its residual energy ranks 0: its refit would be
    refuted by the rotor channel (:func:`~..evidence.refuted_by_rotor_channel`), and on
    a winding-heating campaign a compliance that grew the voltage residual 3.3-fold
    ranked first and took the budget.

    A contact member fitted on its impacts (``impact_fit``) ranks first (1 + score) when
    the data's force transient energy exceeds the current model's by more than
    :data:`~..impacts.IMPACT_ENERGY_RATIO` (``sc["impacts"]``, the ratio): a rattling
    contact's sample-wise signature is not reproducible, so its linearised score is
    near 0 (0.003 on a 0.15 mm gap with a Hertzian contact, energy ratio 523, where the
    six other tuning campaigns of that generator give 0.8-3.6).

    A probe family whose fitted signature is dominated by the probe on a non-physical
    edge of the range (``sc["at_bound"]``, :func:`edge_dominated`: the 1e4 N/m
    mount) ranks 0, as its refit would end at that bound and not earn
    (:func:`~..evidence.at_bound`)."""
    score = float(np.nan_to_num(sc.get("score", math.nan)))
    if sc.get("impacts"):
        return 1.0 + score
    if sc.get("at_bound"):
        return 0.0
    c = sc.get("channel", 0)
    shares, excess = sc.get("channel_shares"), sc.get("channel_excess")
    if (sc.get("transmission") and shares is not None and len(shares) > 1
            and shares[1] < -ROTOR_WORSE_SHARE):
        return 0.0
    if not c or shares is None or excess is None or c >= len(shares):
        return score
    if excess[c] <= CHANNEL_EXCESS_MIN:
        return score
    return max(score, float(shares[c]))


def components_for(names: Sequence[str], prepared: Sequence[PreparedTest],
                    preds: Sequence[np.ndarray], lead: float) -> dict:
    """Candidate components configured from the residual (cogging period; the stroke
    window a position-dependent friction starts from)."""
    out = {}
    for n in names:
        if n == "cogging":
            out[n] = CANDIDATES[n].component(
                periods_per_rev=best_rotor_period(prepared, preds, lead_m_per_rad=lead))
        elif n == "flexibility":
            from ..localise import residual_spectrum
            sp = residual_spectrum(prepared, [pt.y[0] - yp[0] for pt, yp in zip(prepared, preds)],
                                   min_hz=5.0)
            f0 = float(np.clip(sp.get("peak_hz", 100.0), 5.0, 1000.0)) if sp else 100.0
            out[n] = CANDIDATES[n].component(frequency_hz=f0)
        elif n == "position_friction":
            win = stroke_window(prepared, preds)
            out[n] = (CANDIDATES[n].component(centre_m=win[0], width_m=win[1]) if win
                      else CANDIDATES[n].component())
        else:
            out[n] = CANDIDATES[n].component()
    return out


def compatible(rig: Rig, component) -> bool:
    """Whether ``component`` can join the rig's components (one transmission at most,
    no duplicate name)."""
    names = {c.name for c in rig.components}
    if component.name in names:
        return False
    return not (component.transmission and any(c.transmission for c in rig.components))

