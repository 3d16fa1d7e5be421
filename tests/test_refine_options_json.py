"""refine.options.options_from_mapping / options_to_json: RefineOptions fields from JSON values
(``--options``) and back, every bad name or type refused with a message naming it."""
from __future__ import annotations

import json

import pytest

from ycbvss.refine.matching import FlowOptions
from ycbvss.refine.options import RefineOptions, options_from_mapping, options_to_json


def test_json_values_become_the_fields_types():
    kw = options_from_mapping({"edge_sigmas_px": [4, 2, 1], "axis_hold": "narrow,medium", "alpha": 3,
                               "max_iters": 4.0, "flow": {"winsize": 21}, "table_contact": False})
    assert kw["edge_sigmas_px"] == (4, 2, 1) and kw["max_iters"] == 4 and isinstance(kw["max_iters"], int)
    assert kw["flow"] == FlowOptions(winsize=21) and kw["alpha"] == 3
    opt = RefineOptions(**kw)
    assert opt.axis_hold == "narrow,medium" and opt.table_contact is False
    # and back to plain JSON, which parses to the same options
    back = json.loads(json.dumps(options_to_json(kw)))
    assert options_from_mapping(back) == kw


@pytest.mark.parametrize("bad, msg", [
    ({"alpah": 1.0}, "did you mean 'alpha'"),
    ({"max_iters": 2.5}, "RefineOptions.max_iters: expected an integer"),
    ({"use_edge": 1}, "RefineOptions.use_edge: expected bool"),
    ({"alpha": "5"}, "RefineOptions.alpha: expected float"),
    ({"flow": {"win": 3}}, "RefineOptions.flow"),
])
def test_bad_names_and_types_are_refused(bad, msg):
    with pytest.raises(ValueError, match=msg.replace("(", r"\(")):
        options_from_mapping(bad)
