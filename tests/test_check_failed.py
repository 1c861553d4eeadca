"""A check that fails after the solve: the results written stand, the failure is said in one
line, recorded in result.json, and the exit status is 4.

The yield check runs on the device after the solve; a device error there (an H200 at n = 8192
once stopped with CUDA error 700 in it, after result.json was written) must not turn a finished
run into a traceback and exit 1.
"""

import json
from pathlib import Path

import pytest

from warpcontact.cli import main
from warpcontact.numerics import yielding

ROOT = Path(__file__).resolve().parents[1]


def failing_check(*args, **kwargs):
    raise RuntimeError("Warp CUDA error 700: an illegal memory access was encountered")


@pytest.fixture
def hertz_case(tmp_path):
    text = (ROOT / "examples" / "hertz.toml").read_text().replace("n = 128", "n = 32")
    path = tmp_path / "case.toml"
    path.write_text(text)
    return path


def test_solve_with_a_failing_yield_check_writes_its_results_and_exits_4(tmp_path, capsys, monkeypatch, hertz_case):
    monkeypatch.setattr(yielding, "_state_yield_check", failing_check)
    out = tmp_path / "out"
    rc = main(["solve", str(hertz_case), "--out", str(out), "--quiet"])
    err = capsys.readouterr().err
    assert rc == 4, err
    assert "Traceback" not in err
    lines = [ln for ln in err.splitlines() if "yield check failed" in ln]
    assert len(lines) == 1, err
    assert "CUDA error 700" in lines[0]
    result = json.loads((out / "result.json").read_text())
    assert result["complete"] and result["converged"], "the solve's results are whole"
    assert result["yielded"] is None
    assert result["yield_check"]["failed"] and "CUDA error 700" in result["yield_check"]["reason"]
    assert (out / "fields.npz").exists()


def test_solve_with_a_working_yield_check_exits_0(tmp_path, capsys, hertz_case):
    """The same run with the check as it is: exit 0 and a check that ran (the test above is not
    the code path of every run)."""
    rc = main(["solve", str(hertz_case), "--out", str(tmp_path / "out"), "--quiet"])
    assert rc == 0, capsys.readouterr().err
    result = json.loads((tmp_path / "out" / "result.json").read_text())
    assert "failed" not in result["yield_check"]
    assert result["yielded"] in (True, False)
