"""Errors a user can act on."""


class InputError(ValueError):
    """A bad input value. ``key`` names the input (a case-file key or an argument)."""

    def __init__(self, key: str, problem: str):
        self.key = key
        self.problem = problem
        # "sphere.E = 310 Pa is ...": a problem that starts with the value reads on from the key
        super().__init__(f"{key} {problem}" if problem.startswith("= ") else f"{key}: {problem}")


class ConvergenceError(RuntimeError):
    """A solve that did not converge, where a converged state was required."""


class NonFiniteError(FloatingPointError):
    """A traction or displacement became NaN or infinite during a solve."""


class OutputError(OSError):
    """An output file that could not be written: no space left, a read-only file system, a quota,
    an I/O error, a folder that cannot be made. What was written before is left as it was.

    Attributes:
        path: the file that could not be written.
        errno, strerror: the system's error.
        action: what failed ("write", "create the folder", "remove the earlier run's").
        needed_bytes: the size of the file being written [bytes], or None.
        free_bytes: the space left on its file system [bytes] when known, else None.
        hint: what to do, one sentence (may be empty).
    """

    def __init__(self, path, errno_: int | None, strerror: str | None, action: str = "write",
                 needed_bytes: int | None = None, free_bytes: int | None = None, hint: str = ""):
        self.path = str(path)
        self.action = action
        self.needed_bytes = needed_bytes
        self.free_bytes = free_bytes
        self.hint = hint
        super().__init__(errno_, strerror or "error", self.path)

    def __str__(self) -> str:
        import errno

        reason = (self.strerror or "error").lower() if self.strerror else "error"
        text = f"cannot {self.action} {self.path}: {reason}"
        if self.errno in (errno.ENOSPC, errno.EDQUOT) and self.needed_bytes is not None:
            text += f" (the file needs about {human_bytes(self.needed_bytes)}"
            if self.free_bytes is not None:
                text += f"; {human_bytes(self.free_bytes)} free there"
            text += ")"
        if self.hint:
            text += f"; {self.hint}"
        return text

    def with_hint(self, hint: str) -> "OutputError":
        """The same error with ``hint`` (what to do) added after the reason."""
        hint = f"{self.hint}; {hint}" if self.hint else hint
        return OutputError(self.path, self.errno, self.strerror, self.action, self.needed_bytes, self.free_bytes, hint)


def human_bytes(n: int) -> str:
    """``1.9 MiB``, ``600 KiB``, ``812 B``: a size in bytes in binary units (as ``df -h``), 2-3 digits."""
    n = float(n)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB"):
        if abs(n) < 1024 or unit == "TiB":
            return f"{n:.0f} {unit}" if unit == "B" or abs(n) >= 100 else f"{n:.3g} {unit}"
        n /= 1024
    raise AssertionError("unreachable")
