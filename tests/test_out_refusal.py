"""``--out`` that cannot take the outputs is refused before anything runs, for every command: an
existing file where a folder is wanted (an existing folder where ``schema`` wants a file), a
folder below a file, a folder that cannot be written in. Exit 2, one line naming --out, nothing
solved (the solvers' entry points are replaced by a trap) and nothing written.
"""

import os
import time
from pathlib import Path

import pytest

from warpcontact import api
from warpcontact.studies import batch, runner, stress_study, sweep
from warpcontact.cli import EXIT_INPUT, _parser, check_out, main

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

#: every command with --out and arguments that would start its work (a solve, a sweep, Table 2)
COMMANDS = {
    "solve": ["solve", EXAMPLES / "hertz.toml"],
    "gross-slip": ["gross-slip", EXAMPLES / "table2_k080_dz5e-5.toml"],
    "pull-off": ["pull-off", EXAMPLES / "pull_off_dmt.toml"],
    "fretting": ["fretting", EXAMPLES / "fretting_steel.toml"],
    "table2": ["table2", "--no-adhesion", "--n", "16"],
    "figure": ["figure", EXAMPLES / "hertz.toml"],
    "sweep": ["sweep", EXAMPLES / "sweep_k_tau.toml", "--workers", "1"],
    "stress": ["stress", EXAMPLES / "hertz.toml"],
    "fit": ["fit", EXAMPLES / "fit_k_tau.toml", "--workers", "1"],
    "schema": ["schema"],
    "surface": ["surface", "--size", "1e-7", "--rms-height", "1e-9"],
}
FILE_OUT = {"schema"}  # --out names a file; the others' a folder


def test_every_command_with_out_is_covered():
    """The list above is the parser's: a new command with --out gets tested here."""
    sub = next(a for a in _parser()._actions if a.__class__.__name__ == "_SubParsersAction")
    with_out = {name for name, p in sub.choices.items() if any("--out" in a.option_strings for a in p._actions)}
    assert with_out == set(COMMANDS)


def _unwritable(tmp_path: Path) -> Path:
    """A folder this process cannot write in: a read-only one (not for root, who writes anyway),
    else /sys/kernel (sysfs: refused to root too), else the test is skipped."""
    if os.geteuid() != 0:
        folder = tmp_path / "read_only"
        folder.mkdir()
        folder.chmod(0o555)
        return folder
    folder = Path("/sys/kernel")
    try:
        (folder / ".warpcontact-test").touch()
    except OSError:
        return folder
    pytest.skip("no folder here that root cannot write in")


def _bad_out(kind: str, command: str, tmp_path: Path) -> Path:
    a_file = tmp_path / "a_file"
    a_file.write_text("not a folder\n")
    if kind == "existing file or folder":  # the wrong kind of thing
        if command in FILE_OUT:
            return tmp_path  # a folder where the file should go
        return a_file
    if kind == "below a file":
        return a_file / "sub" / ("schema.json" if command in FILE_OUT else "out")
    folder = _unwritable(tmp_path)
    return folder / "new" / ("schema.json" if command in FILE_OUT else "out")


@pytest.fixture
def trapped(monkeypatch):
    """The entry points of every command's work, replaced by a trap: reaching one fails the test."""
    def trap(*args, **kwargs):
        raise AssertionError("the command started its work despite a bad --out")

    for module, name in ((runner, "run_path"), (runner, "build"), (api, "run_gross_slip"), (api, "run_pull_off"),
                         (stress_study, "subsurface_stress"), (sweep, "run_sweep"), (sweep, "load_sweep"),
                         (batch, "run_tasks")):
        monkeypatch.setattr(module, name, trap)
    import warpcontact.schema

    monkeypatch.setattr(warpcontact.schema, "schema_json", trap)


@pytest.mark.parametrize("kind", ["existing file or folder", "below a file", "unwritable folder"])
@pytest.mark.parametrize("command", list(COMMANDS))
def test_a_bad_out_is_refused_before_anything_runs(command, kind, tmp_path, capsys, trapped):
    out = _bad_out(kind, command, tmp_path)
    before = sorted(p.name for p in tmp_path.rglob("*"))
    start = time.perf_counter()
    status = main([*map(str, COMMANDS[command]), "--out", str(out), "--quiet"] if command != "schema"
                  else [*COMMANDS[command], "--out", str(out)])
    elapsed = time.perf_counter() - start
    err = capsys.readouterr().err
    assert status == EXIT_INPUT, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("warpcontact: error: --out: "), err
    assert elapsed < 2.0  # the check and the parser: 1e-3 s; a solve or a cluster would take seconds
    assert sorted(p.name for p in tmp_path.rglob("*")) == before  # nothing made, no probe left


@pytest.mark.parametrize("command", ["solve", "schema"])
def test_a_good_out_passes_and_leaves_nothing(command, tmp_path):
    """A folder that does not exist yet (two levels) passes; the check makes nothing there."""
    out = tmp_path / "new" / "deeper" / ("schema.json" if command in FILE_OUT else "out")
    check_out(out, command in FILE_OUT)
    assert list(tmp_path.iterdir()) == []
    (tmp_path / "existing").mkdir()
    check_out(tmp_path / "existing", False)  # an earlier run's folder: reused
    check_out(tmp_path / "existing" / "schema.json", True)
    (tmp_path / "existing" / "schema.json").write_text("{}")
    check_out(tmp_path / "existing" / "schema.json", True)  # schema overwrites its own file
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["existing", "schema.json"]
