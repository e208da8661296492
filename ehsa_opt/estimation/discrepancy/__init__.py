"""Model-discrepancy workflow (SPEC §7–9): find where simulation and measurement
disagree, name the missing effect from a library of physical candidates, add it,
re-identify and show the gap shrink on held-out data.

Modules: :mod:`.fit` (collocation + IPOPT re-identification, predictions),
:mod:`.localise` (residual maps and structure statistics), :mod:`.candidates`
(candidate library and signature scores), :mod:`.workflow` (the decision), :mod:`.results` (settings and result objects).
"""

from .candidates import CANDIDATES, Candidate, signature_scores
from .fit import FitOutcome, Rig, fit_group, predict, prepare_tests
from .localise import Localisation, localise
from .terms import TermProposal, discover_term
from .results import (
    NONE_OF_CATALOGUE,
    CandidateResult,
    DiscrepancyResult,
    DiscrepancySettings,
)
from .workflow import run_discrepancy, split_tests

__all__ = ["CANDIDATES", "Candidate", "signature_scores", "FitOutcome", "Rig", "fit_group",
           "predict", "prepare_tests", "Localisation", "localise", "CandidateResult",
           "DiscrepancyResult", "DiscrepancySettings", "run_discrepancy", "split_tests",
           "NONE_OF_CATALOGUE", "TermProposal", "discover_term"]
