"""Materials and the composite elastic constants of a sphere-flat pair (MODEL.md section 1).

Body 1 is the sphere (asperity), body 2 the flat. All quantities in SI units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import InputError


@dataclass(frozen=True)
class Material:
    """An isotropic, linear-elastic material.

    Attributes:
        E: Young's modulus [Pa].
        nu: Poisson ratio [-], in (-1, 0.5].
        yield_strength: uniaxial yield strength S_Y [Pa].
        hardness: indentation hardness H [Pa].
        name: free text, for reports.
    """

    E: float
    nu: float
    yield_strength: float = math.inf
    hardness: float = math.inf
    name: str = ""

    def __post_init__(self):
        label = self.name or "material"
        _check_positive(f"{label}.E", self.E)
        if not (isinstance(self.nu, (int, float)) and math.isfinite(self.nu) and -1.0 < self.nu <= 0.5):
            raise InputError(f"{label}.nu", f"must lie in (-1, 0.5], got {self.nu!r}")
        _check_positive(f"{label}.yield_strength", self.yield_strength, allow_inf=True)
        _check_positive(f"{label}.hardness", self.hardness, allow_inf=True)

    @property
    def G(self) -> float:
        """Shear modulus G = E / (2 (1 + nu)) [Pa]."""
        return self.E / (2.0 * (1.0 + self.nu))


def _check_positive(key: str, value, allow_inf: bool = False):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(key, f"must be a number, got {value!r}")
    if math.isnan(value) or (math.isinf(value) and not allow_inf) or value <= 0.0:
        raise InputError(key, f"must be a positive finite number, got {value!r}")


@dataclass(frozen=True)
class MaterialPair:
    """Composite constants of the sphere (body 1) on the flat (body 2).

    Attributes:
        sphere: material of body 1.
        flat: material of body 2.
    """

    sphere: Material
    flat: Material

    def _sum(self, per_body) -> float:
        """``per_body(sphere) + per_body(flat)``: the two half-spaces' compliances add (in series)."""
        return per_body(self.sphere) + per_body(self.flat)

    @property
    def E_star(self) -> float:
        """Composite modulus, 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2 [Pa]."""
        return 1.0 / self._sum(lambda m: (1.0 - m.nu**2) / m.E)

    @property
    def A(self) -> float:
        """Tangential compliance A = (1 - nu1)/G1 + (1 - nu2)/G2 [1/Pa]."""
        return self._sum(lambda m: (1.0 - m.nu) / m.G)

    @property
    def B(self) -> float:
        """Tangential compliance B = nu1/G1 + nu2/G2 [1/Pa]."""
        return self._sum(lambda m: m.nu / m.G)

    @property
    def D(self) -> float:
        """Normal-tangential coupling D = (1 - 2 nu1)/G1 - (1 - 2 nu2)/G2 [1/Pa]; 0 for identical bodies."""
        s, f = self.sphere, self.flat
        return (1.0 - 2.0 * s.nu) / s.G - (1.0 - 2.0 * f.nu) / f.G

    @property
    def dundurs_beta(self) -> float:
        """Dundurs' second parameter beta = D / (2 A) [-]."""
        return self.D / (2.0 * self.A)

    @property
    def mindlin_compliance(self) -> float:
        """(2 - nu1)/G1 + (2 - nu2)/G2 [1/Pa], the compliance in Mindlin's tangential displacement."""
        return self._sum(lambda m: (2.0 - m.nu) / m.G)

    @property
    def softer(self) -> Material:
        """The material of lower yield strength (it sets the von Mises shear limit)."""
        return self.sphere if self.sphere.yield_strength <= self.flat.yield_strength else self.flat


#: The paper's Table 1: copper asperity.
COPPER = Material(E=106e9, nu=0.33, yield_strength=200e6, hardness=1.0e9, name="copper")
#: The paper's Table 1: hardened steel flat.
HARDENED_STEEL = Material(E=205e9, nu=0.31, yield_strength=345e6, hardness=6.2e9, name="hardened steel")
#: The paper's pair: copper sphere (R = 10 um) on a hardened steel flat.
PAPER_PAIR = MaterialPair(COPPER, HARDENED_STEEL)
