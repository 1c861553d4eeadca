"""Solvers: each holds its buffers and launches kernels from ``warpcontact.kernels``."""

from .normal import NormalSolver

__all__ = ["NormalSolver"]
