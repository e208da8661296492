"""Results and settings of the model-discrepancy workflow: :class:`DiscrepancySettings`
(validated at construction), :class:`CandidateResult` (one candidate's re-identification
and its evidence) and :class:`DiscrepancyResult` (what :func:`~.workflow.run_discrepancy`
returns; ``.plot()`` returns the figures and ``.write()`` writes them, both delegating to
:mod:`ehsa_opt.plots.discrepancy`)."""

from __future__ import annotations

import dataclasses
from typing import Any
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...physics.friction import DYNAMIC_LAWS
from .candidates import CANDIDATES
from ..fit_result import FitResult
from ..identify_result import force_relative_error_percent
from .prepared import PreparedTest
from .rig import Rig
from .localise import Localisation
from .budget import MAX_MEMBER_FITS
from .criterion import DEFAULT_CRITERION, Criterion
from .terms import TermProposal

__all__ = ["DiscrepancySettings", "CandidateResult", "DiscrepancyResult", "NONE_OF_CATALOGUE",
           "UNDECIDED", "BASE_INADEQUATE", "CHANNEL_MEMBERS", "DEFAULT_MEMBERS"]

#: The answer when the residual is structured but no catalogue effect earns.
NONE_OF_CATALOGUE = "none of the catalogue"
#: The answer of a run cut at its time budget before any effect was named.
UNDECIDED = "undecided"
#: The answer when no member is named but the evaluation error stays far above the noise
#: floor (the criterion's ``inadequate_ratio``): the base model cannot represent the rig
#: there; the message says how (the residual's physical support).
BASE_INADEQUATE = "base model inadequate"

#: The members beside the catalogue's components that
#: :attr:`DiscrepancySettings.candidates` may list (:mod:`.members`: the drive's lag, a
#: delay of the force record, the force and voltage sensors' dynamics, the friction's
#: drift).
CHANNEL_MEMBERS: tuple[str, ...] = ("drive_lag", "force_lag", "force_sensor", "voltage_sensor",
                                    "friction_drift")

#: The members searched by default: every catalogue component, the drive's lag, the
#: force record's delay and the campaign's friction drift (tried only on a campaign whose
#: tests state their run order).  The force sensor's dynamics is listed by choice
#: (``candidates=(..., "force_sensor")``, ``--candidates``): with the static friction law
#: as the base model, a low-pass of the force also smooths the friction's jump at a
#: reversal, which a presliding transition would explain — it is offered by default once
#: the base law has that transition.
DEFAULT_MEMBERS: tuple[str, ...] = (*CANDIDATES, "drive_lag", "force_lag", "friction_drift")


@dataclass(frozen=True)
class DiscrepancySettings:
    """Settings of :func:`run_discrepancy`.

    Attributes
    ----------
    candidates : tuple of str
        Members to consider: catalogue components and :data:`CHANNEL_MEMBERS`
        (default :data:`DEFAULT_MEMBERS`).
    top : int
        How many of the best-ranked candidates are re-identified per round.
    max_effects : int
        At most this many effects are named (rounds of the search).
    max_tests : int or None
        Use at most this many tests (spread over the grid), e.g. for quick runs.
    max_fit_tests : int or None
        Candidate re-identifications use at most this many of the fit tests
        (spread over the grid; the decision always uses all held-out tests) — the
        wall-time and memory budget of a large grid.
    max_iter : int
        IPOPT iterations per fit.
    max_samples : int or None
        Sine tests longer than this are cropped to their last ``max_samples``
        samples (whole recorded tests such as EMPS are never cropped).
    seed : int
        Seeds the held-out split and the sparse regression's folds.
    jobs : int
        Parallel processes for the candidate re-identifications.
    discover : bool
        Run the data-driven term discovery on the final residual.
    max_member_fits : int or None
        The work budget: member fits the search may start (default
        :data:`~.budget.MAX_MEMBER_FITS`; None: none), charged in the
        order the search asks for them (:mod:`.budget`), so the answer is the same for
        any ``jobs`` and any machine load.  When it is spent no further member fit
        starts: a round in progress is decided on the members already re-identified
        (widening and look-ahead paths are skipped), no new round starts, and the result
        says where it was cut (``success`` False, ``cut`` the reason).
    wall_cap_s : float or None
        A wall-time safety cap, s (None: none).  Not a budget: when it binds, fits stop
        at the best point reached and no further fit starts, like the work budget, and
        the answer says that it depends on the machine's speed and load.  A fit the cap
        cut at its start point is not fitted (``CandidateResult.cut_at_deadline``): it
        takes no decision and is named as work left.
    presliding : bool
        Offer the base model's friction law a presliding transition (adopted only when
        it earns on the baseline, :func:`~.presliding.adopt_presliding`; every model
        judged then has its own presliding term).  False (default): the static friction
        map only — with the candidates' parameters fitted without the term, a member
        fitted to the voltage (a winding heating) can end with a friction compromise
        that the term then counts against it (see :mod:`.presliding`).
    dynamic_friction : bool
        Offer the base model the dynamic (LuGre) friction law, fitted from the static
        optimum by a continuation in the bristle stiffness and adopted when it earns
        (:mod:`.dynamic_law`).  False (default): the static map only — on the second
        generator's clean campaigns the dynamic law halves the held-out error but leaves
        3.9–8.1 × the noise floor (1.0–2.1 × the true model's error, which is itself
        3.7–4.1 × that floor: their force noise is coloured), and on a stiff-contact
        campaign one of its stages did not finish within 15 minutes.
    dynamic_law : {"lugre", "lugre_stribeck"}
        The dynamic law offered with ``dynamic_friction``: ``"lugre"`` (the bristle's
        steady state the Simscape curve) or ``"lugre_stribeck"`` (the generalised
        Stribeck curve with its exponent and Olsson's fading micro-damping,
        :mod:`~ehsa_opt.physics.friction`).
    scheduler : str or distributed.Client, optional
        Make the member fits on a Dask cluster (its scheduler's address, or a client)
        instead of ``jobs`` local processes: the same fits in the same order, so the
        same answer as the local run (:mod:`.executor`).
    criterion : Criterion
        The thresholds every verdict is decided by (:class:`~.criterion.Criterion`,
        validated at its construction; the default is the documented one).
    """

    candidates: tuple[str, ...] = DEFAULT_MEMBERS
    top: int = 3
    max_effects: int = 3
    max_tests: int | None = None
    max_fit_tests: int | None = 8
    max_iter: int = 150
    max_samples: int | None = 1500
    seed: int = 0
    jobs: int = 1
    discover: bool = True
    max_member_fits: int | None = MAX_MEMBER_FITS
    wall_cap_s: float | None = None
    presliding: bool = False
    dynamic_friction: bool = False
    dynamic_law: str = "lugre"
    criterion: Criterion = DEFAULT_CRITERION
    scheduler: Any = None

    def __post_init__(self) -> None:
        if self.scheduler is not None and not (
                isinstance(self.scheduler, str) and self.scheduler.strip()
                or callable(getattr(self.scheduler, "submit", None))):
            raise ValueError(f"DiscrepancySettings: scheduler must be None, a Dask scheduler "
                             f"address (e.g. tcp://127.0.0.1:8786) or a distributed.Client, "
                             f"got {self.scheduler!r}")
        if not isinstance(self.criterion, Criterion):
            raise ValueError(f"DiscrepancySettings: criterion must be a Criterion, got "
                             f"{type(self.criterion).__name__}")
        if self.wall_cap_s is not None and not (
                isinstance(self.wall_cap_s, (int, float)) and not isinstance(self.wall_cap_s, bool)
                and math.isfinite(self.wall_cap_s) and self.wall_cap_s > 0):
            raise ValueError(f"DiscrepancySettings: wall_cap_s must be None or a number of "
                             f"seconds > 0, got {self.wall_cap_s!r}")
        if self.max_member_fits is not None and not (
                isinstance(self.max_member_fits, int) and not isinstance(self.max_member_fits, bool)
                and self.max_member_fits >= 1):
            raise ValueError(f"DiscrepancySettings: max_member_fits must be None or an "
                             f"integer >= 1 (member fits), got {self.max_member_fits!r}")
        if self.dynamic_law not in DYNAMIC_LAWS:
            raise ValueError(f"DiscrepancySettings: dynamic_law must be one of "
                             f"{', '.join(repr(x) for x in DYNAMIC_LAWS)}, got "
                             f"{self.dynamic_law!r}")
        unknown = [c for c in self.candidates if c not in CANDIDATES
                   and c not in CHANNEL_MEMBERS]
        if unknown:
            raise ValueError(f"DiscrepancySettings: unknown candidates {unknown} "
                             f"(known: {', '.join((*CANDIDATES, *CHANNEL_MEMBERS))})")
        for name in ("top", "max_effects", "jobs"):
            v = getattr(self, name)
            if not (isinstance(v, int) and v >= 1):
                raise ValueError(f"DiscrepancySettings: {name} must be an integer >= 1, "
                                 f"got {v!r}")
        for name in ("max_tests", "max_fit_tests"):
            v = getattr(self, name)
            if v is not None and not (isinstance(v, int) and v >= 1):
                raise ValueError(f"DiscrepancySettings: {name} must be None or an integer >= 1")
        if self.max_samples is not None and not (isinstance(self.max_samples, int)
                                                 and self.max_samples >= 50):
            raise ValueError("DiscrepancySettings: max_samples must be None or an integer >= 50")


@dataclass
class CandidateResult:
    """One candidate in one round: its rank score, re-identification and errors."""

    effect: str
    applicable: bool
    score: float
    chi2: float
    round: int = 1
    fitted: bool = False
    fit: FitResult | None = None
    error_before: float = math.nan  # relative force error, % (evaluation set)
    error_after: float = math.nan
    excess_reduction: float = math.nan
    delta_bic_fit: float = math.nan
    delta_bic_heldout: float = math.nan
    sse_heldout: float = math.nan
    sse_reduction: float | None = None
    sse_route: bool = False  # the other-channel (SSE) route was open (force at its floor)
    block_reduction: float = math.nan  # median per-block excess reduction (own evidence)
    blocks_judged: int = 0
    earns_by: str = ""  # "total excess" | "own evidence" | ""
    resolved: bool = True
    #: effect parameters fitted on a non-physical bound of their range (never earns)
    at_bound: list[str] = field(default_factory=list)
    #: the output channel its signature is seen best on (0 force, 1 voltage), and the
    #: held-out ΔBIC per channel (the winner is chosen on its own channel's)
    own_channel: int | None = None
    channel_dbic: list[float] = field(default_factory=list)
    earns: bool = False
    #: "" or why the run's time budget cut its fit at its start point
    #: (:func:`~.candidate_fit.not_fitted`): then it is not fitted — it cannot earn,
    #: open or complete a look-ahead path, and it is work left at the budget
    cut_at_deadline: str = ""
    parameters: dict[str, float] = field(default_factory=dict)
    intervals: dict[str, tuple[float, float] | None] = field(default_factory=dict)
    per_test_after: list[float] = field(default_factory=list)
    predictions: list[np.ndarray] | None = None
    rig: Rig | None = None

    def as_dict(self) -> dict:
        return {"effect": self.effect, "round": self.round, "applicable": self.applicable,
                "score": self.score, "chi2": self.chi2,
                "re_identified": bool(self.fitted and not self.cut_at_deadline),
                "cut_at_deadline": self.cut_at_deadline or None,
                "error_before": self.error_before, "error_after": self.error_after,
                "excess_error_reduction": self.excess_reduction,
                "delta_bic_fit": self.delta_bic_fit, "delta_bic_heldout": self.delta_bic_heldout,
                "sse_excess_reduction": self.sse_reduction,
                "sse_route_open": bool(self.sse_route),
                "median_block_excess_reduction": self.block_reduction,
                "blocks_judged": int(self.blocks_judged), "earns_by": self.earns_by,
                "earns_its_parameters": bool(self.earns), "at_bound": list(self.at_bound),
                "own_channel": self.own_channel,
                "delta_bic_heldout_per_channel": list(self.channel_dbic),
                "parameters": self.parameters,
                "intervals_95": {k: list(v) if v else None for k, v in self.intervals.items()},
                "ipopt_status": self.fit.message if self.fit else None,
                "fit_seconds": self.fit.seconds if self.fit else None}


@dataclass
class DiscrepancyResult:
    """Outcome of the workflow (mirrors ``OptimizeResult``: ``success``, ``message``).

    Attributes
    ----------
    effect : str
        The named effects joined by " + ", ``"none"`` (the residual is noise),
        ``"none of the catalogue"`` (structured, explained by the proposed term),
        :data:`BASE_INADEQUATE` (no member earns, no term names what is missing,
        and the error stays above the criterion's ``inadequate_ratio`` × the noise floor) or :data:`UNDECIDED` (cut
        before anything was named).
    effects : list of str
        The named effects in the order they were added.
    error_before, error_after : float
        Relative force error (%) on the evaluation set before and after the named
        effects (after = before when none).
    evaluation : str
        ``"held-out"``, ``"validation set"`` or ``"all data"``.
    candidates : list of CandidateResult
        All rounds, each in rank order.
    steps : list of dict
        Per named effect: effect, error after adding it, parameters.
    term : TermProposal or None
        The data-driven term proposed for the final residual.
    noise_floor : float
        Relative force error (%) of the measurement noise alone (evaluation set).
    validation : dict or None
        EMPS-style validation record: open-loop position errors (see :mod:`.openloop`).
    notes : list of str
        Bench checks the data failed (used anyway) and why a round was not run
        (e.g. the residual is already at the noise floor).
    cut : str
        Empty, or where the work budget (``settings.max_member_fits``) or the wall-time
        safety cap (``settings.wall_cap_s``) cut the run: the answer
        is then partial (the named effects are those the completed work supports).
    voltage_skew : dict or None
        The voltage-skew check of the baseline (``found``, ``delay_s`` in s, > 0 when
        the voltage is sampled late, its ΔBIC on the fit and held-out tests, the share
        of the held-out voltage excess it explains, ``message``); None when the check
        was not run (no voltage channel).  When found, the voltage was re-aligned by
        ``delay_s`` before the rounds; None also when no delay of the grid fits better
        than none.
    baseline_presliding : dict or None
        The presliding transition of the base model's friction law
        (:meth:`~.presliding.PreslidingLaw.as_dict`: ``adopted``, ``lengths_m``, the
        baseline's ``amplitudes_N``, its ``error_before``/``error_after`` without / with
        the transition, %, ``excess_reduction``, ΔBIC, ``message``); None when not
        tried.  When adopted, ``error_before`` and every error, SSE and ΔBIC of the
        search are of models with their own presliding term.
    """

    success: bool
    message: str
    effect: str
    error_before: float
    error_after: float
    evaluation: str
    candidates: list[CandidateResult]
    baseline: FitResult
    rig: Rig
    fit_tests: list[PreparedTest]
    heldout_tests: list[PreparedTest]
    baseline_pred: list[np.ndarray]
    loc_before: Localisation
    loc_after: Localisation | None
    n_eff: dict[str, float]
    seconds: float
    data_path: str = ""
    effects: list[str] = field(default_factory=list)
    steps: list[dict] = field(default_factory=list)
    term: TermProposal | None = None
    noise_floor: float = math.nan
    validation: dict | None = None
    notes: list[str] = field(default_factory=list)
    cut: str = ""
    voltage_skew: dict | None = None
    baseline_presliding: dict | None = None
    #: the criterion the verdicts were decided by
    criterion: Criterion = DEFAULT_CRITERION
    #: member fits charged to the work budget (:mod:`.budget`)
    member_fits: int = 0

    @property
    def winner(self) -> CandidateResult | None:
        """The last named effect's result (its predictions are the final model's)."""
        named = [c for c in self.candidates if self.effects and c.earns
                 and c.effect == self.effects[-1]]
        return named[-1] if named else None

    @property
    def eval_tests(self) -> list[PreparedTest]:
        return self.heldout_tests or self.fit_tests

    def per_test_errors(self) -> list[dict]:
        """Relative force error per test, before and after, fit and held-out."""
        rows = []
        w = self.winner
        allp = self.fit_tests + self.heldout_tests
        for k, pt in enumerate(allp):
            m = pt.weight > 0  # resolved samples (recorded tests: corners left out)
            before = force_relative_error_percent(self.baseline_pred[k][0][m], pt.y[0][m])
            after = (force_relative_error_percent(w.predictions[k][0][m], pt.y[0][m])
                     if w is not None and w.predictions is not None else before)
            rows.append({"test": pt.test.label, "file": pt.test.file,
                         "set": "fit" if k < len(self.fit_tests) else "held-out",
                         "error_before": before, "error_after": after})
        return rows

    def as_dict(self) -> dict:
        return {"effect": self.effect, "effects": self.effects, "steps": self.steps,
                "error_before": self.error_before, "error_after": self.error_after,
                "evaluation": self.evaluation, "noise_floor_percent": self.noise_floor,
                "success": self.success, "message": self.message, "data": self.data_path,
                "fit_tests": [p.test.file for p in self.fit_tests],
                "heldout_tests": [p.test.file for p in self.heldout_tests],
                "baseline": {"parameters": self.baseline.parameters,
                             "ipopt_status": self.baseline.message,
                             "fit_seconds": self.baseline.seconds},
                "effective_samples": self.n_eff,
                "criterion": {
                    "rule": "an effect (or a discovered term) is named only if its refit removes "
                            "at least min_excess_reduction of the held-out relative force error "
                            "above the noise floor, 1 - sqrt(e1^2 - en^2)/sqrt(e0^2 - en^2), and "
                            "dBIC = N_eff ln(SSE_new/SSE_old) + k ln(N_eff) < 0 on the fit and "
                            "on the held-out tests; effects are added one at a time (lowest "
                            "held-out dBIC first) until none earns; the SSE alternative is "
                            "judged per channel, and only where the force error has no excess "
                            "beyond noise or another channel's excess (SSE/N - 1) is larger "
                            "than the force's; a generator member (own channel the voltage) "
                            "on that channel whatever the force's excess, with the held-out "
                            "dBIC per channel and the force not refuting it; "
                            "or on the effect's own evidence: dBIC < 0 on both, "
                            "the held-out error not growing and the median over contiguous "
                            "blocks of the held-out records (documented disturbances masked) "
                            "of the excess removed at least min_excess_reduction; an "
                            "effect's amplitude interval (Newey-West) must exclude zero; a "
                            "data-driven term only when the residual is not white (Ljung-Box)",
                    "criterion": dataclasses.asdict(self.criterion),
                    "noise_floor_percent": self.noise_floor},
                "term": self.term.as_dict() if self.term else None,
                "validation": self.validation,
                "notes": self.notes,
                "partial": bool(self.cut), "cut": self.cut or None,
                "member_fits": self.member_fits,
                "not_fitted_at_budget": [{"effect": c.effect, "round": c.round,
                                          "why": c.cut_at_deadline}
                                         for c in self.candidates if c.cut_at_deadline],
                "voltage_skew": self.voltage_skew,
                "baseline_presliding": self.baseline_presliding,
                "localisation_before": self.loc_before.as_dict(),
                "localisation_after": self.loc_after.as_dict() if self.loc_after else None,
                "per_test": self.per_test_errors(),
                "candidates": [c.as_dict() for c in self.candidates],
                "seconds": self.seconds}

    def plot(self, ax=None) -> dict:
        """The report's figures keyed by file name (residual maps, zoom, per-test errors,
        ranking), writing nothing; multi-panel figures, so ``ax`` is accepted for the
        common protocol and not used. Delegates to :mod:`ehsa_opt.plots.discrepancy`."""
        from ...plots import discrepancy as pd
        return pd.figures(self)

    def write(self, out_dir: str | Path) -> list[Path]:
        """Write the report's figures into ``out_dir`` as PNG files (atomically); returns
        their paths."""
        from ...plots import discrepancy as pd
        return pd.all_figures(self, Path(out_dir))

    def summary(self) -> str:
        """The answer in words and one line per judged candidate (round, effect, verdict,
        held-out error after its refit, %)."""
        lines = [self.message]
        for c in self.candidates:
            if c.fitted:
                lines.append(f"  round {c.round}: {c.effect:<22s} "
                             f"{'EARNS (' + c.earns_by + ')' if c.earns else 'does not earn':<28s}"
                             f" error after {c.error_after:.3f} %")
        return "\n".join(lines)

    def table(self) -> Any:
        """The judged candidates as a tidy table (one row per candidate and round)."""
        from ...utils.tables import tidy_table
        rows = [c for c in self.candidates if c.fitted]
        return tidy_table({
            "round": [c.round for c in rows], "effect": [c.effect for c in rows],
            "earns": [bool(c.earns) for c in rows], "earns_by": [c.earns_by for c in rows],
            "error_before_pct": [c.error_before for c in rows],
            "error_after_pct": [c.error_after for c in rows],
            "delta_bic_heldout": [c.delta_bic_heldout for c in rows]},
            {"round": "-", "earns": "", "effect": "", "earns_by": "",
             "delta_bic_heldout": "-"})

    def save(self, out_dir: str | Path) -> list[Path]:
        """Write ``discrepancy.json`` (standard JSON) and the figures (``figures/``) into
        ``out_dir``; returns the paths written."""
        import json

        from ...utils.io import atomic_write_json
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        figs = self.write(out / "figures")
        js = out / "discrepancy.json"
        atomic_write_json(js, json.loads(json.dumps(self.as_dict(), default=_plain)), indent=2)
        return [js, *figs]


# ------------------------------------------------------------------ the workflow


def _plain(o: Any) -> Any:
    """numpy scalars and arrays as JSON values (the rest as text)."""
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    return str(o)
