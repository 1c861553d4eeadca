"""``wc.path``: the states as they are solved, with their fields where asked for, the same as
``wc.solve``'s."""

import numpy as np

import warpcontact as wc
from warpcontact.records.case import tomllib
from pathlib import Path

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "figure2c.toml"


def test_path_yields_each_states_fields_where_asked_and_they_are_solves():
    with open(EXAMPLE, "rb") as f:
        case = tomllib.load(f)
    case["grid"]["n"] = 24
    case["load"]["steps"] = 2
    case["solver"]["device"] = "cpu"
    solved = wc.solve(case, fields="all")
    states = list(wc.path(case, fields=True))
    assert len(states) == len(solved.states) == 4
    for k, (s, f) in enumerate(zip(states, solved.fields)):
        assert s["force"] == solved.states[k]["force"]
        assert set(s["fields"]) == set(f)
        for name, a in f.items():
            assert np.array_equal(s["fields"][name], a), (k, name)
    assert "fields" not in next(iter(wc.path(case)))  # summaries alone by default
