"""Errors a user can act on."""


class InputError(ValueError):
    """A bad input value. ``key`` names the input (a case-file key or an argument)."""

    def __init__(self, key: str, problem: str):
        self.key = key
        self.problem = problem
        super().__init__(f"{key}: {problem}")


class ConvergenceError(RuntimeError):
    """A solve that did not converge, where a converged state was required."""


class NonFiniteError(FloatingPointError):
    """A traction or displacement became NaN or infinite during a solve."""
