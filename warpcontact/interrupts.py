"""Stops asked for by the user or the system: Ctrl-C (SIGINT), SIGTERM and SIGHUP, handled alike.

Batch schedulers (SLURM, PBS, Kubernetes, a Dask worker being shut down) stop a job with SIGTERM,
and a closed terminal sends SIGHUP. :func:`install` (the command line does it first) makes both
raise :class:`Stop`, a KeyboardInterrupt, as Ctrl-C raises KeyboardInterrupt, so every command's
Ctrl-C handling (finished states written, ``"interrupted": true``) serves all three. The exit
status is :func:`exit_status`: 128 + the signal's number, as shells report a process the signal
ended (130 SIGINT, 143 SIGTERM, 129 SIGHUP).

Two places where an interrupt must not land:

- a destructor: Python raises the exception wherever the main thread is when the signal arrives.
  If that is inside an object's ``__del__`` (Warp arrays free device memory there, and the
  solvers make and drop many array views), Python cannot raise it: it prints "Exception ignored
  in ..." and goes on, and the interrupt is lost. A Table 2 run went on to the end and exited 0
  after such a Ctrl-C (CI, tests/test_nothing_lost.py). :func:`install` replaces
  ``sys.unraisablehook`` so that a swallowed interrupt is remembered instead of printed;
  :func:`check`, called by the solvers once per iteration launch and per turn, raises it there.
- the bookkeeping of a finished state or case (its summary added to the lists and its result
  file written): inside :func:`deferred` a signal is remembered and raised when the block ends, so
  the lists and the files on disk always agree. Once a command has caught a stop (it calls
  :func:`stopping`), later signals are only remembered: they do not cut the writing of what
  finished.
"""

from __future__ import annotations

import contextlib
import signal
import sys

#: the signals handled, by name; each raises Stop (SIGINT: only where Python's own handler was set)
SIGNALS = ("SIGINT", "SIGTERM", "SIGHUP")


class Stop(KeyboardInterrupt):
    """A stop asked for by a signal. ``signum``: its number (signal.SIGTERM, ...)."""

    def __init__(self, signum: int):
        self.signum = int(signum)
        super().__init__(signal_name(signum))


_pending: KeyboardInterrupt | None = None  # swallowed by a destructor, raised by check()
_previous_hook = None
_received: int | None = None  # the first stop signal of the run
_defer_depth = 0
_deferred: int | None = None  # a signal that arrived inside deferred(), raised at its end
_stopping = False  # a command caught a stop and is writing what finished: later signals wait


def signal_name(signum: int | None) -> str:
    """``SIGTERM`` for 15; ``SIGINT`` for None (a KeyboardInterrupt raised without a signal)."""
    if signum is None:
        return "SIGINT"
    try:
        return signal.Signals(signum).name
    except ValueError:
        return f"signal {signum}"


def _hook(unraisable):
    global _pending
    if unraisable.exc_type is not None and issubclass(unraisable.exc_type, KeyboardInterrupt):
        value = unraisable.exc_value
        _pending = value if isinstance(value, KeyboardInterrupt) else unraisable.exc_type()
        return
    (_previous_hook or sys.__unraisablehook__)(unraisable)


def _handler(signum, frame):
    global _received, _deferred
    if _received is None:
        _received = signum
    if _defer_depth > 0 or _stopping:
        _deferred = signum if _deferred is None else _deferred
        return
    raise Stop(signum)


def install():
    """Handle SIGTERM and SIGHUP as Ctrl-C (raise :class:`Stop`), take over Ctrl-C where Python's
    own handler is set, and remember interrupts that a destructor swallowed (see the module
    docstring). A signal that is ignored (nohup, a shell's background job) or has a handler of the
    host program's is left so. Main thread only; installing twice does nothing more."""
    global _previous_hook
    if _previous_hook is None:
        _previous_hook = sys.unraisablehook
        sys.unraisablehook = _hook
    for name in SIGNALS:
        signum = getattr(signal, name, None)
        if signum is None:  # SIGHUP: not on Windows
            continue
        current = signal.getsignal(signum)
        if current is _handler:
            continue
        if name == "SIGINT" and current is not signal.default_int_handler:
            continue
        if name != "SIGINT" and current is not signal.SIG_DFL:  # nohup's SIG_IGN, or a host program's own
            continue
        try:
            signal.signal(signum, _handler)
        except ValueError:  # not the main thread: signals stay as they are
            return


def check():
    """Raise the interrupt a destructor swallowed, if there was one."""
    global _pending
    if _pending is not None:
        exc, _pending = _pending, None
        raise exc


@contextlib.contextmanager
def deferred(raise_after: bool = True):
    """A block that a stop signal does not cut: one that arrives inside is remembered and raised
    as :class:`Stop` when the outermost such block ends (``raise_after``), or only remembered
    (``raise_after=False``: the last writes of a run that is stopping or done)."""
    global _defer_depth
    _defer_depth += 1
    try:
        yield
    except BaseException:
        _end_deferred(raise_after=False)  # the block's own exception goes on
        raise
    _end_deferred(raise_after)


def _end_deferred(raise_after: bool):
    global _defer_depth, _deferred
    _defer_depth -= 1
    if _defer_depth == 0 and _deferred is not None:
        signum, _deferred = _deferred, None
        if raise_after:
            raise Stop(signum)


def received() -> int | None:
    """The number of the first stop signal this process received, or None."""
    return _received


def stop_signal(exc: BaseException | None = None) -> int:
    """The signal behind an interrupt: ``exc``'s when it is a :class:`Stop` (remembered as the run's
    stop when none was received: a Stop raised by code, not by the handler), else the first one
    received, else SIGINT (a KeyboardInterrupt raised without a signal is Ctrl-C)."""
    global _received
    if isinstance(exc, Stop):
        if _received is None:
            _received = exc.signum
        return exc.signum
    return _received if _received is not None else int(signal.SIGINT)


def stopping(exc: BaseException | None = None) -> int:
    """A command caught a stop and writes what finished before it exits: from now on signals are
    only remembered, so that a second one does not cut those writes. Returns the stop's signal
    (:func:`stop_signal`). For the command line, whose process ends next; a library function that
    catches a stop guards its writes with :func:`deferred` instead."""
    global _stopping
    _stopping = True
    return stop_signal(exc)


def exit_status(exc: BaseException | None = None) -> int:
    """128 + the number of the signal that stopped the run: 130 SIGINT, 143 SIGTERM, 129 SIGHUP."""
    return 128 + stop_signal(exc)


def describe(exc: BaseException | None = None) -> str:
    """``interrupted`` for Ctrl-C, ``interrupted (SIGTERM)`` for the others: how messages begin."""
    signum = stop_signal(exc)
    return "interrupted" if signum == signal.SIGINT else f"interrupted ({signal_name(signum)})"


def reset():
    """Forget received, deferred and swallowed stops: a new run begins (the command line calls it
    first; tests run several commands in one process)."""
    global _received, _deferred, _pending, _defer_depth, _stopping
    _received = _deferred = _pending = None
    _defer_depth = 0
    _stopping = False
