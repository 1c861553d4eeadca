"""Progress of long work on stderr: a bar over the items of a known count (states of a path, cells
of a table, cases of a sweep) or a counter for a search of unknown length (gross slip).

On a terminal one line is redrawn in place (``\\r``)::

    table2 [#######-----------------------] 3/12  it 412  res 8.1e-11  0:42 elapsed, eta 2:06  n 128 k_tau 0.80

Elsewhere (a log file, a pipe) each finished item prints one whole line, and the in-between
redraws (:meth:`Progress.status`) are left out so that logs stay readable.

Inside a long step (a state solved in turns, up to ``solver.max_turns`` of them), the turn and its
relative change, the number the turns stop on, show on the bar open now (:func:`show_turn`, which
``runner.build`` makes the solver's ``on_turn``): redrawn at most every ``TURN_REDRAW_S`` on a
terminal; in a log a whole line once the step has run ``TURN_LOG_S`` without one, and as often
after::

    solve [######------------------------] 1/5  turn 412, change 3.1e-05  0:42 elapsed, eta 2:48

With ``quiet`` nothing is printed. Example::

    with Progress("solve", total=len(path), quiet=args.quiet) as bar:   # close() ends the line
        for k, approach in enumerate(path):
            info = solver.step(state, approach)
            bar.update(k + 1, iterations=info.iterations, residual=info.residual)
"""

from __future__ import annotations

import shutil
import sys
import time
import weakref

#: Characters of the bar.
WIDTH = 30
#: least time between two redraws of a step's turn on a terminal [s]
TURN_REDRAW_S = 0.2
#: in a log, least time since the last line before a step's turn gets a line of its own [s]
TURN_LOG_S = 30.0


def clock(seconds: float) -> str:
    """``m:ss`` (or ``h:mm:ss``) of a duration in s."""
    m, s = divmod(int(round(seconds)), 60)
    h, m = divmod(m, 60)
    return f"{h}:{m:02d}:{s:02d}" if h else f"{m}:{s:02d}"


class Progress:
    """A progress line on ``stream`` (default stderr).

    Args:
        label: first word of the line (the command).
        total: number of items, or None for a search of unknown length (a counter, no bar).
        quiet: print nothing.
        stream: where to write (default ``sys.stderr`` at construction).
        live: redraw in place; default: whether ``stream`` is a terminal.
        start: items finished before (skipped cases): counted in k/total, not in the rate.
    """

    #: the bar drawn on a terminal now, for :func:`write_above`
    active: Progress | None = None
    #: the bar made last and not closed (a weak reference: a bar dropped unclosed goes with it),
    #: where :func:`show_turn` writes
    _open = None

    def __init__(self, label: str, total: int | None = None, quiet: bool = False, stream=None,
                 live: bool | None = None, start: int = 0):
        self.label, self.total, self.quiet, self.start = label, total, quiet, start
        self.stream = sys.stderr if stream is None else stream
        self.live = bool(getattr(self.stream, "isatty", lambda: False)()) if live is None else live
        self.t0 = time.perf_counter()
        self.drawn = ""  # the line shown now (live only)
        self.done = start  # items finished, as the last update or status said
        self.shown_at = self.t0  # when a line was last shown
        self.turn_redraw_s, self.turn_log_s = TURN_REDRAW_S, TURN_LOG_S
        Progress._open = weakref.ref(self)

    def text(self, done: int, iterations=None, residual=None, extra: str = "", inside: str = "") -> str:
        """``label [###---] done/total  it N  res R  inside  elapsed, eta  extra``; ``label done/?``
        without a total. ``inside``: the work inside the current item (a step's turn), before the
        timing so that a narrow terminal keeps it."""
        if self.total:
            filled = min(WIDTH, WIDTH * done // self.total)
            parts = [f"{self.label} [{'#' * filled}{'-' * (WIDTH - filled)}] {done}/{self.total}"]
        else:
            parts = [f"{self.label} {done}/?"]
        if iterations is not None:
            parts.append(f"it {iterations}")
        if residual is not None:
            parts.append(f"res {residual:.1e}")
        if inside:
            parts.append(inside)
        elapsed = time.perf_counter() - self.t0
        timing = f"{clock(elapsed)} elapsed"
        if self.total and done > self.start and done < self.total:
            timing += f", eta {clock(elapsed / (done - self.start) * (self.total - done))}"
        parts.append(timing)
        if extra:  # last: a narrow terminal cuts it first
            parts.append(extra)
        return "  ".join(parts)

    def update(self, done: int, iterations=None, residual=None, extra: str = "") -> None:
        """``done`` items are finished: redraw (terminal) or print a whole line (log)."""
        self.done = done
        if not self.quiet:
            self._show(self.text(done, iterations, residual, extra), keep=not self.live)

    def status(self, done: int, iterations=None, residual=None, extra: str = "") -> None:
        """Work inside the current item (a state of the current cell): redrawn on a terminal only."""
        self.done = done
        if not self.quiet and self.live:
            self._show(self.text(done, iterations, residual, extra), keep=False)

    def turn(self, turn: int, change: float) -> None:
        """A turn of the step being solved, and its relative change [-]: ``turn K, change X`` after
        the items done (before the timing), redrawn on a terminal at most every ``turn_redraw_s``
        (TURN_REDRAW_S); in a log a whole line once ``turn_log_s`` (TURN_LOG_S) have passed since
        the last line."""
        if self.quiet:
            return
        if time.perf_counter() - self.shown_at < (self.turn_redraw_s if self.live else self.turn_log_s):
            return
        self._show(self.text(self.done, inside=f"turn {turn}, change {change:.1e}"), keep=not self.live)

    def write(self, line: str, always: bool = False) -> None:
        """A line for the record (a finished cell's result) above the bar, which is drawn again;
        ``always``: printed when quiet too (a warning, an error)."""
        if self.quiet and not always:
            return
        bar = self.drawn
        self._show(line, keep=True)
        if bar:
            self._show(bar, keep=False)

    def close(self) -> None:
        """End the redrawn line (terminal), so that what follows starts on a line of its own."""
        if self.drawn:
            print(file=self.stream, flush=True)
        self.drawn = ""
        if Progress.active is self:
            Progress.active = None
        if Progress._open is not None and Progress._open() is self:
            Progress._open = None

    def __enter__(self) -> Progress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def _show(self, line: str, keep: bool) -> None:
        self.shown_at = time.perf_counter()
        if not self.live:
            print(line, file=self.stream, flush=True)
            return
        if not keep:  # a wrapped line cannot be redrawn
            line = line[: max(20, shutil.get_terminal_size().columns - 1)]
        pad = " " * max(0, len(self.drawn) - len(line))
        back = "\r" if self.drawn or not keep else ""
        print(f"{back}{line}{pad}", end="\n" if keep else "", file=self.stream, flush=True)
        self.drawn = "" if keep else line
        Progress.active = self if self.drawn else None


def show_turn(turn: int, change: float) -> None:
    """A turn of the step being solved (``ContactSolver.on_turn``), shown on the bar open now
    (:meth:`Progress.turn`); nothing when none is open (the Python API)."""
    bar = Progress._open() if Progress._open is not None else None
    if bar is not None:
        bar.turn(turn, change)


def write_above(line: str, stream=None) -> None:
    """Print ``line`` (a warning) on ``stream`` (default stderr), above the bar drawn there now, if any."""
    stream = sys.stderr if stream is None else stream
    bar = Progress.active
    if bar is not None and bar.stream is stream:
        bar.write(line, always=True)
    else:
        print(line, file=stream, flush=True)


def end_line() -> None:
    """End the line of the bar being drawn now, if any (before an error message)."""
    if Progress.active is not None:
        Progress.active.close()
