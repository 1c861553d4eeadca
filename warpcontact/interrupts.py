"""Ctrl-C that lands in a destructor is not lost.

Python raises KeyboardInterrupt wherever the main thread is when SIGINT arrives. If that is inside
an object's ``__del__`` (Warp arrays free device memory there, and the solvers make and drop many
array views), Python cannot raise it: it prints "Exception ignored in ..." and goes on, and the
interrupt is lost. A Table 2 run went on to the end and exited 0 after such a Ctrl-C (CI,
tests/test_nothing_lost.py).

:func:`install` (the command line does it) replaces ``sys.unraisablehook`` so that a swallowed
KeyboardInterrupt is remembered instead of printed; :func:`check`, called by the solvers once per
iteration and per turn, raises it there, where the commands catch it.
"""

from __future__ import annotations

import sys

_pending = False
_previous_hook = None


def _hook(unraisable):
    global _pending
    if unraisable.exc_type is not None and issubclass(unraisable.exc_type, KeyboardInterrupt):
        _pending = True
        return
    (_previous_hook or sys.__unraisablehook__)(unraisable)


def install():
    """Remember KeyboardInterrupts that Python could not raise (see the module docstring)."""
    global _previous_hook
    if _previous_hook is None:
        _previous_hook = sys.unraisablehook
        sys.unraisablehook = _hook


def check():
    """Raise the KeyboardInterrupt a destructor swallowed, if there was one."""
    global _pending
    if _pending:
        _pending = False
        raise KeyboardInterrupt
