"""Progress bars (warpcontact.records.progress): the bar's text, whole lines in a log, redraws on a
terminal, silence with --quiet; and the command line's progress on stderr."""

import io
import json
import re
import subprocess
import sys
from pathlib import Path

from warpcontact.records.progress import WIDTH, Progress, clock, write_above

ROOT = Path(__file__).resolve().parents[1]


class Terminal(io.StringIO):
    """A stream that says it is a terminal."""

    def isatty(self):
        return True


def test_bar_text_for_k_of_total():
    bar = Progress("table2", total=12, stream=io.StringIO())
    bar.t0 -= 30.0  # 30 s elapsed: 3 of 12 cells -> 10 s a cell, 9 left
    text = bar.text(3, 412, 8.1e-11, "n 128 k_tau 0.80")
    filled = WIDTH * 3 // 12
    assert text == (f"table2 [{'#' * filled}{'-' * (WIDTH - filled)}] 3/12  it 412  res 8.1e-11  0:30 elapsed, "
                    "eta 1:30  n 128 k_tau 0.80")
    assert bar.text(12).startswith(f"table2 [{'#' * WIDTH}] 12/12  0:30 elapsed") and "eta" not in bar.text(12)
    assert bar.text(0).startswith(f"table2 [{'-' * WIDTH}] 0/12  ") and "eta" not in bar.text(0)


def test_eta_counts_only_the_items_done_now():
    bar = Progress("sweep", total=10, stream=io.StringIO(), start=6)  # 6 cases finished before
    bar.t0 -= 20.0
    assert bar.text(8).endswith("0:20 elapsed, eta 0:20")  # 2 done in 20 s, 2 left


def test_search_of_unknown_length_has_a_counter_and_no_bar():
    bar = Progress("gross-slip", stream=io.StringIO())
    text = bar.text(5, 98, 4.7e-10, "bisect delta_x 4.5e-11 m")
    assert re.fullmatch(r"gross-slip 5/\?  it 98  res 4\.7e-10  0:00 elapsed  bisect delta_x 4\.5e-11 m", text), text
    assert "[" not in text and "eta" not in text


def test_log_gets_one_whole_line_per_finished_item():
    log = io.StringIO()  # not a terminal
    bar = Progress("solve", total=3, stream=log)
    assert not bar.live
    for k in range(1, 4):
        bar.status(k - 1, 10, 1e-3, "inside the item")  # left out of a log
        bar.update(k, 42, 5e-11, "F_z 3.295e-07 N")
    bar.write("result: F_z 3.295e-07 N")
    bar.close()
    text = log.getvalue()
    assert "\r" not in text and "inside the item" not in text
    lines = text.splitlines()
    assert len(lines) == 4 and text.endswith("\n")
    bars = [f"solve [{'#' * (WIDTH * k // 3)}{'-' * (WIDTH - WIDTH * k // 3)}] {k}/3" for k in (1, 2, 3)]
    assert [ln.split("  ")[0] for ln in lines[:3]] == bars
    assert all(re.search(r"  it 42  res 5\.0e-11  0:00 elapsed(, eta 0:00)?  F_z 3\.295e-07 N$", ln)
               for ln in lines[:3])
    assert lines[3] == "result: F_z 3.295e-07 N"


def test_terminal_redraws_one_line():
    term = Terminal()
    bar = Progress("pull-off", total=5, stream=term)
    assert bar.live
    bar.update(1, 100, 1e-3, "a long extra text")
    bar.status(1, 7, 1e-4)  # shorter: padded over the longer line
    first, second = term.getvalue().split("\r")[1:]
    assert "\n" not in term.getvalue() and len(second) == len(first)
    bar.write("a line for the record")  # above the bar, which is drawn again
    assert term.getvalue().split("\r")[3].startswith("a line for the record") and term.getvalue().count("\n") == 1
    assert term.getvalue().split("\r")[4].startswith("pull-off [")
    bar.close()
    assert term.getvalue().endswith("\n") and term.getvalue().count("\n") == 2
    bar.close()  # a second close adds nothing
    assert term.getvalue().count("\n") == 2


def test_quiet_prints_nothing_but_what_must_be_seen():
    for stream in (io.StringIO(), Terminal()):
        bar = Progress("table2", total=4, quiet=True, stream=stream)
        bar.status(0, extra="n 128")
        bar.update(1, 10, 1e-11)
        bar.write("table2 [1/4] n 128 ...: delta_x_max ...")
        bar.close()
        assert stream.getvalue() == ""
        bar.write("warpcontact: warning: a warning", always=True)
        assert stream.getvalue() == "warpcontact: warning: a warning\n"


def test_warnings_go_above_a_bar_being_drawn():
    term = Terminal()
    with Progress("solve", total=2, stream=term) as bar:
        bar.update(1, 10, 1e-11)
        write_above("warpcontact: warning: coarse", stream=term)
        assert term.getvalue().split("\r")[2].startswith("warpcontact: warning: coarse")
        assert term.getvalue().split("\r")[3].startswith("solve [")
    assert Progress.active is None and term.getvalue().endswith("\n")
    log = io.StringIO()
    write_above("warpcontact: warning: no bar", stream=log)
    assert log.getvalue() == "warpcontact: warning: no bar\n"


def test_clock():
    assert [clock(s) for s in (0, 5.4, 65, 3723)] == ["0:00", "0:05", "1:05", "1:02:03"]


def fast_gross_slip_case(tmp_path, *extra_solver_lines):
    """The paper's k_tau = 0.80 case on 32 cells with the flat made of the sphere's material: no
    Dundurs coupling, one turn per state, about a second for the whole search."""
    text = (ROOT / "examples" / "table2_k080_dz5e-5.toml").read_text()
    text = text.replace("n = 96", "n = 32").replace("E = 205e9\nnu = 0.31", "E = 106e9\nnu = 0.33")
    text += "".join(f"{line}\n" for line in extra_solver_lines)
    p = tmp_path / "case.toml"
    p.write_text(text)
    return p


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "warpcontact.cli", *map(str, args)], capture_output=True, text=True,
                          timeout=600)


def stderr_lines(r):
    return [ln for ln in r.stderr.splitlines() if not ln.startswith("Warp CUDA warning")]


def test_gross_slip_prints_progress_and_none_with_quiet(tmp_path):
    case = fast_gross_slip_case(tmp_path)
    r = run_cli("gross-slip", case, "--out", tmp_path / "gs")
    assert r.returncode == 0, r.stderr
    states = json.loads((tmp_path / "gs" / "result.json").read_text())["states"]
    lines = stderr_lines(r)
    progress = [ln for ln in lines if ln.startswith("gross-slip ")]
    assert len(progress) == len(states) and "\r" not in r.stderr  # a log: one whole line per state
    assert re.match(r"gross-slip 1/\?  it \d+  res \d\.\de-\d\d  0:\d\d elapsed  normal delta_x 0\.0000e\+00 m, "
                    r"\d+ stick cells$", progress[0]), progress[0]
    assert "bisect" in progress[-1] and lines[-1].startswith("delta_x_max = ")
    r = run_cli("gross-slip", case, "--out", tmp_path / "gs", "--quiet")
    assert r.returncode == 0 and stderr_lines(r) == [], r.stderr
