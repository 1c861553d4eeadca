"""Bad input campaign: every bad case file of tests/test_case.py, and the mistakes only a run or
the command line can see, through the command line; the API calls with their own checks.

Each must give exit status 2 and one line on stderr that names the input (the case-file key, the
argument, or the file), with no traceback; through the API, a ValueError (InputError) or a
TypeError. The command line runs in-process (``warpcontact.cli.main``: an escaping exception
fails the test) and, for a sample of each kind, as the real ``python -m warpcontact.cli``.
"""

from __future__ import annotations

import copy
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
import warp as wp
from test_case import BAD_CASES, BAD_FILES, PAPER_TOML, paper_dict, to_toml

from warpcontact import api
from warpcontact.physics.adhesion import SMC, Dugdale
from warpcontact.records.case import case_from_dict
from warpcontact.cli import main
from warpcontact.errors import InputError
from warpcontact.physics.friction import Coulomb, TaborVonMises
from warpcontact.physics.geometry import Grid

NO_CUDA = wp.get_cuda_device_count() == 0


def write(tmp_path, d: dict, name="case.toml") -> Path:
    f = tmp_path / name
    f.write_text(to_toml(d), encoding="utf-8")
    return f


def check_refused(rc: int, err: str, key: str) -> str:
    """Exit 2, one line on stderr naming ``key``, no traceback; returns the line."""
    lines = [ln for ln in err.strip().splitlines() if not ln.startswith("Warp CUDA warning")]
    assert rc == 2, err
    assert "Traceback" not in err, err
    assert len(lines) == 1, err
    assert lines[0].startswith("warpcontact: error: ") and key in lines[0], (key, lines[0])
    return lines[0]


def run_main(capsys, *argv) -> tuple[int, str]:
    rc = main([str(a) for a in argv])
    return rc, capsys.readouterr().err


# ---------------------------------------------------------------------------------------------
# Case files: the whole table of tests/test_case.py, through `warpcontact solve`.


@pytest.mark.parametrize("mutate, key", [pytest.param(m, k, id=i) for i, m, k in BAD_CASES])
def test_bad_case_on_the_command_line(tmp_path, capsys, mutate, key):
    d = copy.deepcopy(paper_dict())
    mutate(d)
    rc, err = run_main(capsys, "solve", write(tmp_path, d), "--out", tmp_path / "out", "--quiet")
    check_refused(rc, err, f"{key}: ")
    assert not (tmp_path / "out").exists()  # refused before anything is written


@pytest.mark.parametrize("make", [pytest.param(m, id=i) for i, m in BAD_FILES])
def test_bad_file_on_the_command_line(tmp_path, capsys, make):
    path = make(tmp_path)
    rc, err = run_main(capsys, "solve", path, "--out", tmp_path / "out", "--quiet")
    check_refused(rc, err, f"{path}: ")


def _through_a_file(tmp_path):
    f = tmp_path / "case.toml"
    f.write_text(PAPER_TOML, encoding="utf-8")
    return f / "more.toml"  # a path through a file: NotADirectoryError


def _no_permission(tmp_path):
    f = tmp_path / "locked.toml"
    f.write_text(PAPER_TOML, encoding="utf-8")
    f.chmod(0)
    return f


def _empty(tmp_path):
    f = tmp_path / "empty.toml"
    f.write_bytes(b"")
    return f


def _binary(tmp_path):
    f = tmp_path / "binary.toml"
    f.write_bytes(bytes(range(256)))
    return f


#: Files the table of tests/test_case.py does not hold: (maker, expected key; None: the file's path).
MORE_FILES = [
    pytest.param(_through_a_file, None, id="path-through-a-file"),
    pytest.param(_no_permission, None, id="no-read-permission", marks=pytest.mark.skipif(
        hasattr(os, "geteuid") and os.geteuid() == 0, reason="root reads a file without permissions")),
    pytest.param(_empty, "sphere", id="empty-file"),  # valid TOML, nothing in it: the first required table
    pytest.param(_binary, None, id="binary-file"),
]


@pytest.mark.parametrize("make, key", MORE_FILES)
def test_unreadable_files_on_the_command_line(tmp_path, capsys, make, key):
    path = make(tmp_path)
    rc, err = run_main(capsys, "solve", path, "--out", tmp_path / "out", "--quiet")
    check_refused(rc, err, f"{key or path}: ")


# ---------------------------------------------------------------------------------------------
# What the case checks let through and a run refuses, and command-line arguments.

SMC_OK = {"law": "smc", "sigma_max": 1.8394e7, "tau_max": 1.8394e7, "delta_n": 1e-9, "delta_t": 1e-9}
TABOR_080 = {"law": "tabor", "k_tau": 0.8}


def _no_yield(d):
    d["friction"] = dict(TABOR_080)
    del d["sphere"]["yield_strength"], d["flat"]["yield_strength"]


def _pulled_apart(d):
    d["friction"] = dict(TABOR_080)
    d["load"] = {"path": [[0.0, 0.0, -1e-11]]}


def _set_solver(**kw):
    def mutate(d):
        d["solver"] = {**d.get("solver", {}), **kw}

    return mutate


def _add(table, value):
    def mutate(d):
        d[table] = copy.deepcopy(value)

    return mutate


def _identity(d):
    pass


#: command, mutation of the paper's case, extra arguments, expected key in the message.
RUN_TIME = [
    pytest.param("solve", _set_solver(device="cuda"), [], "solver.device", id="cuda-device-absent",
                 marks=pytest.mark.skipif(not NO_CUDA, reason="a CUDA device is present: this checks the refusal "
                                                              "on machines without one")),
    pytest.param("solve", _set_solver(device="cuda:99"), [], "solver.device", id="cuda-ordinal-absent"),
    pytest.param("solve", _identity, ["--device", "tpu"], "solver.device", id="override-device-unknown"),
    pytest.param("solve", _identity, ["--device", "cuda:99"], "solver.device", id="override-device-cuda-99"),
    pytest.param("solve", _identity, ["--fft", "cupy"], "solver.fft", id="override-fft-cupy-on-cpu"),
    pytest.param("solve", lambda d: d["grid"].update(n=200_000), [], "grid.n", id="grid-too-large-for-memory"),
    pytest.param("gross-slip", _identity, [], "friction", id="gross-slip-without-friction"),
    pytest.param("gross-slip", _no_yield, [], "sphere.yield_strength", id="gross-slip-tabor-without-yield-strength"),
    pytest.param("gross-slip", _pulled_apart, [], "load.delta_z", id="gross-slip-no-approach"),
    pytest.param("pull-off", _identity, [], "adhesion", id="pull-off-without-adhesion"),
    pytest.param("pull-off", _add("adhesion", SMC_OK), ["--steps", "1"], "--steps", id="pull-off-one-step"),
    pytest.param("pull-off", _add("adhesion", SMC_OK), ["--retract-to", "1e-10"], "--retract-to",
                 id="pull-off-retract-above-approach"),
]


@pytest.mark.parametrize("command, mutate, extra, key", RUN_TIME)
def test_run_time_refusals_on_the_command_line(tmp_path, capsys, command, mutate, extra, key):
    d = copy.deepcopy(paper_dict())
    mutate(d)
    rc, err = run_main(capsys, command, write(tmp_path, d), "--out", tmp_path / "out", "--quiet", *extra)
    check_refused(rc, err, key)


#: (id, arguments after the command, expected key).
TABLE2_ARGS = [
    ("table2-n-under-8", ["--no-adhesion", "--n", "4"], "--n"),
    ("table2-domain-under-the-contact", ["--no-adhesion", "--size-in-a", "1.5"], "--size-in-a"),
    ("table2-unknown-k_tau", ["--no-adhesion", "--k-tau", "0.7"], "--k-tau"),
    ("table2-unknown-delta_z", ["--no-adhesion", "--delta-z-um", "2e-5"], "--delta-z-um"),
    ("table2-device-unknown", ["--no-adhesion", "--k-tau", "0.8", "--delta-z-um", "1e-5", "--device", "tpu"],
     "solver.device"),
]


@pytest.mark.parametrize("args, key", [pytest.param(*c[1:], id=c[0]) for c in TABLE2_ARGS])
def test_table2_arguments(tmp_path, capsys, args, key):
    rc, err = run_main(capsys, "table2", *args, "--out", tmp_path / "t2", "--quiet")
    check_refused(rc, err, key)


#: (id, sweep file text after the base line, expected key).
SWEEP_FILES = [
    ("sweep-unknown-key", '[sweep]\n"friction.k_tua" = [0.5]\n', "sweep.friction.k_tua"),
    ("sweep-k_tau-outside", '[sweep]\n"friction.k_tau" = [0.5, 1.5]\n', "sweep.friction.k_tau"),
    ("sweep-nu-outside", '[sweep]\n"sphere.nu" = [0.33, 0.51]\n', "sweep.sphere.nu"),
    ("sweep-path-not-finite", '[sweep]\n"load.path" = [[[0.0, 0.0, nan]]]\n', "sweep.load.path"),
    ("sweep-not-a-list", '[sweep]\n"friction.k_tau" = 0.5\n', "sweep.friction.k_tau"),
]


@pytest.mark.parametrize("text, key", [pytest.param(*c[1:], id=c[0]) for c in SWEEP_FILES])
def test_sweep_files(tmp_path, capsys, text, key):
    base = write(tmp_path, {**paper_dict(), "friction": TABOR_080}, name="base.toml")
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(f'base = "{base.name}"\n' + text, encoding="utf-8")
    rc, err = run_main(capsys, "sweep", sweep, "--out", tmp_path / "out", "--quiet")
    check_refused(rc, err, key)
    assert not (tmp_path / "out").exists()


# ---------------------------------------------------------------------------------------------
# The real command line, one of each kind: exit 2, one line, no traceback.

SUBPROCESS_SAMPLE = [
    ("missing-key", lambda d: d["sphere"].pop("E"), [], "sphere.E"),
    ("nan", lambda d: d["grid"].update(size=math.nan), [], "grid.size"),
    ("nu-outside", lambda d: d["flat"].update(nu=0.6), [], "flat.nu"),
    ("cuda-ordinal-absent", _identity, ["--device", "cuda:99"], "solver.device"),
]


@pytest.mark.parametrize("mutate, extra, key", [pytest.param(*c[1:], id=c[0]) for c in SUBPROCESS_SAMPLE])
def test_real_command_line(tmp_path, mutate, extra, key):
    d = copy.deepcopy(paper_dict())
    mutate(d)
    r = subprocess.run([sys.executable, "-m", "warpcontact.cli", "solve", str(write(tmp_path, d)), "--out",
                        str(tmp_path / "out"), "--quiet", *extra], capture_output=True, text=True, timeout=600)
    check_refused(r.returncode, r.stderr, key)


def test_real_command_line_non_utf8_file(tmp_path):
    path = dict(BAD_FILES)["non-utf8"](tmp_path)
    r = subprocess.run([sys.executable, "-m", "warpcontact.cli", "solve", str(path), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True, timeout=600)
    assert "not UTF-8" in check_refused(r.returncode, r.stderr, str(path))


# ---------------------------------------------------------------------------------------------
# The API: a ValueError (InputError) naming the input, or a TypeError.


def _paper():
    return case_from_dict(paper_dict())


def _with(**tables):
    return case_from_dict({**paper_dict(), **tables})


#: (id, call, expected exception, expected key or None for a TypeError).
API_CALLS = [
    ("solve-not-a-case", lambda: api.solve(42), TypeError, None),
    ("gross-slip-list-not-a-case", lambda: api.gross_slip([paper_dict()]), TypeError, None),
    ("solve-device-unknown", lambda: api.solve(_paper(), device="tpu"), InputError, "solver.device"),
    ("solve-device-cuda-99", lambda: api.solve(_paper(), device="cuda:99"), InputError, "solver.device"),
    ("solve-dtype-float16", lambda: api.solve(_paper(), dtype="float16"), InputError, "solver.dtype"),
    ("gross-slip-without-friction", lambda: api.gross_slip(_paper()), InputError, "friction"),
    ("pull-off-without-adhesion", lambda: api.pull_off(_paper()), InputError, "adhesion"),
    ("pull-off-zero-steps", lambda: api.pull_off(_with(adhesion=SMC_OK), steps=0), InputError, "steps"),
    ("case-not-a-table", lambda: case_from_dict([1, 2]), InputError, "case"),
    ("grid-n-under-8", lambda: Grid(4, 1e-7), InputError, "grid.n"),
    ("grid-size-inf", lambda: Grid(64, math.inf), InputError, "grid.size"),
    ("smc-negative-sigma", lambda: SMC(-1e8, 1e8, 1e-9, 1e-9), InputError, "adhesion.sigma_max"),
    ("dugdale-nan-h_0", lambda: Dugdale(1e8, math.nan), InputError, "adhesion.h_0"),
    ("coulomb-mu-negative", lambda: Coulomb(-0.1), InputError, "friction.mu"),
    ("tabor-k_tau-1.5", lambda: TaborVonMises(1.5, 2e8), InputError, "friction.k_tau"),
]


@pytest.mark.parametrize("call, exc, key", [pytest.param(*c[1:], id=c[0]) for c in API_CALLS])
def test_api_calls(call, exc, key):
    with pytest.raises(exc) as e:
        call()
    assert isinstance(e.value, (ValueError, TypeError))
    assert "\n" not in str(e.value)
    if key is not None:
        assert e.value.key == key, str(e.value)
    else:
        assert "Case" in str(e.value)  # says what was expected


def test_campaign_size():
    """At least 30 bad inputs go through the command line and 10 through the Python API, so that
    the checks are met where a user meets them."""
    on_cli = len(BAD_CASES) + len(BAD_FILES) + len(MORE_FILES) + len(RUN_TIME) + len(TABLE2_ARGS) + len(SWEEP_FILES)
    assert on_cli >= 30 and len(API_CALLS) >= 10


@pytest.mark.parametrize("argv, meant", [(["grossslip"], "gross-slip"), (["pulloff"], "pull-off"),
                                         (["solve", "case.toml", "--out", "o", "--fields", "nne"], "none")])
def test_a_mistyped_command_or_choice_names_the_one_probably_meant(capsys, argv, meant):
    with pytest.raises(SystemExit) as e:
        main(argv)
    err = capsys.readouterr().err
    assert e.value.code == 2
    assert err.strip().splitlines()[-1].endswith(f"did you mean '{meant}'?"), err
