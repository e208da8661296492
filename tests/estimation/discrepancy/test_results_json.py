"""The discrepancy report's JSON: booleans are JSON booleans (never the string 'False')."""

import json

import numpy as np

from ehsa_opt.estimation.discrepancy.results import CandidateResult
from ehsa_opt.pipeline.discrepancy_report import _json_default
from ehsa_opt.utils.io import json_safe


def test_numpy_bools_become_json_booleans():
    c = CandidateResult("cogging", True, 0.1, 3.0)
    c.earns, c.fitted = np.bool_(False), np.bool_(True)  # what comparisons of arrays give
    doc = json.loads(json.dumps(c.as_dict(), default=_json_default))
    assert doc["earns_its_parameters"] is False
    assert doc["re_identified"] is True
    # a numpy bool reaching the serialiser directly is a boolean too, not str(x)
    assert json.loads(json.dumps({"x": np.bool_(True)}, default=_json_default))["x"] is True
    assert json_safe({"x": np.bool_(False)})["x"] is False
