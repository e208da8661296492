"""Model-discrepancy workflow: find where simulation and measurement disagree, name
the missing effect from a library of physical candidates, add it, re-identify and
show the gap shrink on held-out data.

Modules, one concept each:

* :mod:`.workflow`: the phases of :func:`run_discrepancy`;
* :mod:`.split`: fit and held-out tests;
* :mod:`.fit`: the rig, the prepared tests, the collocation + IPOPT fit of a group
  of parameters and the forward simulation (:func:`predict`);
* :mod:`.polish`: Gauss–Newton refinement on the forward simulation;
* :mod:`.localise`: residual maps and structure statistics;
* :mod:`.candidates`: the catalogue — every member (components, ``force_lag``,
  ``flexibility``), signature scores;
* :mod:`.candidate_fit`: re-identifying one candidate on the current model;
* :mod:`.evidence`: the statistics a model change is measured by;
* :mod:`.criterion`: every threshold a verdict depends on (:class:`Criterion`) and
  the search's policy; :mod:`.judge`: the verdicts, by that criterion;
* :mod:`.budget`: the work budget (member fits) and the wall-time safety cap;
  :mod:`.executor`: local processes or a Dask cluster for the member fits;
* :mod:`.search`: the forward-selection rounds; :mod:`.widen`: widening a round;
  :mod:`.lookahead`: the look-ahead
  through a confounded candidate;
* :mod:`.terms`: a data-driven term for what no catalogue effect explains;
* :mod:`.openloop`: the open-loop validation of the EMPS benchmark (the hold, the
  lag), :mod:`.initial_state`: its initial state from the first 20 samples,
  :mod:`.outputerror`: the output-error fits of its model table;
* :mod:`.results`: settings and result objects.
"""

from .candidates import CANDIDATES, Candidate, signature_scores
from .criterion import Criterion, SearchPolicy
from ..fit_result import FitResult
from .fit import fit_group
from .prepared import prepare_tests
from .rig import Rig, predict
from .localise import Localisation, localise
from .results import (
    NONE_OF_CATALOGUE,
    CandidateResult,
    DiscrepancyResult,
    DiscrepancySettings,
)
from .split import split_tests
from .terms import TermProposal, discover_term
from .workflow import run_discrepancy

__all__ = ["CANDIDATES", "Candidate", "signature_scores", "FitResult", "Rig", "fit_group",
           "predict", "prepare_tests", "Localisation", "localise", "CandidateResult",
           "DiscrepancyResult", "DiscrepancySettings", "run_discrepancy", "split_tests",
           "NONE_OF_CATALOGUE", "TermProposal", "discover_term", "Criterion", "SearchPolicy"]
