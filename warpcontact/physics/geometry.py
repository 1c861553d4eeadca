"""Surface grid and sphere-on-flat geometry (MODEL.md sections 2 and 3)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..errors import InputError

#: Smallest grid the solvers accept (cells per side).
MIN_CELLS = 8


@dataclass(frozen=True)
class Grid:
    """A uniform grid of n x n square cells centred on the first point of contact.

    Tractions are constant over a cell; displacements are taken at cell centres. Arrays on the
    grid have shape (n, n), indexed [row = y, column = x].

    Attributes:
        n: cells per side.
        size: side length of the square domain [m].
    """

    n: int
    size: float

    def __post_init__(self):
        if isinstance(self.n, bool) or not isinstance(self.n, (int, np.integer)):
            raise InputError("grid.n", f"must be an integer, got {self.n!r}")
        if self.n < MIN_CELLS:
            raise InputError("grid.n", f"must be at least {MIN_CELLS}, got {self.n}")
        if isinstance(self.size, bool) or not isinstance(self.size, (int, float)) or not math.isfinite(self.size) or self.size <= 0:
            raise InputError("grid.size", f"must be a positive finite length in m, got {self.size!r}")

    @property
    def shape(self) -> tuple[int, int]:
        return (self.n, self.n)

    @property
    def dx(self) -> float:
        """Cell size [m] (square cells: dy = dx)."""
        return self.size / self.n

    @property
    def dy(self) -> float:
        return self.dx

    @property
    def cell_area(self) -> float:
        """Area of one cell [m^2]."""
        return self.dx * self.dy

    @property
    def x(self) -> np.ndarray:
        """Cell-centre coordinates along x [m], shape (n,), symmetric about 0."""
        return (np.arange(self.n) - 0.5 * (self.n - 1)) * self.dx

    @property
    def y(self) -> np.ndarray:
        """Cell-centre coordinates along y [m], shape (n,)."""
        return self.x

    def mesh(self) -> tuple[np.ndarray, np.ndarray]:
        """(X, Y) cell-centre coordinates [m], each of shape (n, n)."""
        return np.meshgrid(self.x, self.y, indexing="xy")


@dataclass(frozen=True)
class Sphere:
    """A rigidly moved sphere (the asperity) of radius R over the flat.

    Attributes:
        radius: R [m].
        profile: "sphere" for the exact h0 = R - sqrt(R^2 - r^2), "paraboloid" for r^2 / (2 R).
    """

    radius: float
    profile: str = "sphere"

    def __post_init__(self):
        r = self.radius
        if isinstance(r, bool) or not isinstance(r, (int, float)) or not math.isfinite(r) or r <= 0:
            raise InputError("sphere.radius", f"must be a positive finite length in m, got {r!r}")
        if self.profile not in ("sphere", "paraboloid"):
            raise InputError("sphere.profile", f"must be 'sphere' or 'paraboloid', got {self.profile!r}")

    def check_domain(self, grid: Grid):
        """Raise InputError("grid.size", ...) where the exact sphere's gap does not exist on the
        grid (a cell centre at r >= R; the paraboloid has no such limit)."""
        if self.profile == "paraboloid":
            return
        corner = 0.5 * (grid.n - 1) * grid.dx  # the farthest cell centre's |x| and |y|
        if corner * corner + corner * corner >= self.radius**2:
            raise InputError(
                "grid.size",
                f"the domain ({grid.size:g} m across) reaches beyond the sphere's radius {self.radius:g} m",
            )

    def initial_gap(self, grid: Grid) -> np.ndarray:
        """Gap before deformation h0(x, y) [m] at the cell centres, shape (n, n), float64 (on
        CUDA the model makes it on the device: ``kernels/geometry.py``)."""
        self.check_domain(grid)
        X, Y = grid.mesh()
        r2 = X**2 + Y**2
        if self.profile == "paraboloid":
            return r2 / (2.0 * self.radius)
        return r2 / (self.radius + np.sqrt(self.radius**2 - r2))  # = R - sqrt(R^2 - r^2), no cancellation


def profile_note(size: float, sphere) -> str:
    """What a suggested domain side [m] needs of the profile: "" when it fits the sphere's profile,
    else a clause asking for the paraboloid (the exact sphere's gap exists only within r < R, so
    its domain stays below sqrt(2) R)."""
    if getattr(sphere, "profile", "sphere") != "sphere" or size < math.sqrt(2.0) * sphere.radius:
        return ""
    return (f" with sphere.profile = 'paraboloid' (a domain of that side reaches beyond the sphere's radius "
            f"R = {sphere.radius:.4g} m)")
