"""Shear-limit laws (MODEL.md section 5). Each law launches one kernel of kernels/laws.py.

To add a law: write its ``@wp.func`` and kernel in ``kernels/laws.py`` and a small class here
with ``shear_limit(model, pressure, out)`` and ``describe()``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import warp as wp

from warpcontact.kernels import laws

from ..errors import InputError

K_VM_DEFAULT = 1.0 / math.sqrt(3.0)


@dataclass(frozen=True)
class Coulomb:
    """q_max = mu p (plain Coulomb friction, for validation against Cattaneo-Mindlin).

    Attributes:
        mu: friction coefficient [-], >= 0.
    """

    mu: float

    def __post_init__(self):
        if isinstance(self.mu, bool) or not isinstance(self.mu, (int, float)) or not math.isfinite(self.mu) or self.mu < 0:
            raise InputError("friction.mu", f"must be a finite number >= 0, got {self.mu!r}")

    def shear_limit(self, model, pressure: wp.array, out: wp.array):
        """out <- q_max(pressure), scaled units, flattened (n_cells,) arrays."""
        model.launch(laws.coulomb_limit, dim=model.n_cells, inputs=[pressure, model.scalar(self.mu)], outputs=[out])

    def describe(self) -> dict:
        return {"law": "coulomb", "mu": self.mu}


@dataclass(frozen=True)
class TaborVonMises:
    """q_max = min(mu_b p, k_VM sqrt(S_Y^2 - p^2)): Tabor's bond failure of a contaminated
    surface below the crossover pressure, von Mises failure of the softer material above it.

    Tabor, D. (1959), "Junction growth in metallic friction", Proc. R. Soc. A 251, 378-393;
    Shi's slip-incipience mechanism as used by the seed paper.

    Attributes:
        k_tau: surface-to-bulk shear strength ratio [-], in (0, 1).
        yield_strength: S_Y of the softer material [Pa].
        k_vm: T_S / S_Y [-], 1/sqrt(3) (von Mises) by default.
    """

    k_tau: float
    yield_strength: float
    k_vm: float = K_VM_DEFAULT

    def __post_init__(self):
        k = self.k_tau
        if isinstance(k, bool) or not isinstance(k, (int, float)) or not (0.0 < k < 1.0):
            raise InputError("friction.k_tau", f"must lie strictly between 0 and 1, got {k!r}")
        if isinstance(self.k_vm, bool) or not isinstance(self.k_vm, (int, float)) or not math.isfinite(self.k_vm) or self.k_vm <= 0:
            raise InputError("friction.k_vm", f"must be a positive finite number, got {self.k_vm!r}")
        if not (self.yield_strength > 0 and math.isfinite(self.yield_strength)):
            raise InputError("sphere.yield_strength", "the Tabor law needs a finite yield strength of the softer material")

    @property
    def mu_b(self) -> float:
        """Bond-failure friction slope mu_b = k_VM / sqrt(k_tau^-2 - 1) [-]."""
        return self.k_vm / math.sqrt(self.k_tau**-2 - 1.0)

    @property
    def crossover_pressure(self) -> float:
        """p* = k_VM S_Y / sqrt(mu_b^2 + k_VM^2) [Pa]: above it the von Mises branch governs."""
        return self.k_vm * self.yield_strength / math.sqrt(self.mu_b**2 + self.k_vm**2)

    def shear_limit(self, model, pressure, out):
        model.launch(
            laws.tabor_limit,
            dim=model.n_cells,
            inputs=[
                pressure,
                model.scalar(self.mu_b),
                model.scalar(self.k_vm),
                model.scalar(self.yield_strength / model.traction_scale),
            ],
            outputs=[out],
        )

    def describe(self) -> dict:
        return {"law": "tabor", "k_tau": self.k_tau, "k_vm": self.k_vm, "yield_strength": self.yield_strength, "mu_b": self.mu_b}
