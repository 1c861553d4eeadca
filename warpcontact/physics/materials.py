"""Materials and the composite elastic constants of a sphere-flat pair (MODEL.md section 1).

Body 1 is the sphere (asperity), body 2 the flat. All quantities in SI units.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from ..errors import InputError


@dataclass(frozen=True)
class Material:
    """An isotropic, linear-elastic material, or a rigid body (``Material.rigid()``).

    A rigid body is the limit E -> inf: it adds nothing to the pair's compliances (``MaterialPair``),
    has no Poisson ratio, never yields and is never the softer body.

    Attributes:
        E: Young's modulus [Pa]; inf for a rigid body.
        nu: Poisson ratio [-], in (-1, 0.5]; None for a rigid body.
        yield_strength: uniaxial yield strength S_Y [Pa]; inf for a rigid body.
        hardness: indentation hardness H [Pa]; inf for a rigid body.
        name: free text, for reports.
    """

    E: float
    nu: float | None
    yield_strength: float = math.inf
    hardness: float = math.inf
    name: str = ""

    def __post_init__(self):
        label = self.name or "material"
        _check_positive(f"{label}.E", self.E, allow_inf=True)
        if self.is_rigid:
            if self.nu is not None:
                raise InputError(f"{label}.nu", f"a rigid body (E = inf) has no Poisson ratio, got {self.nu!r}; "
                                                "give None (Material.rigid())")
            for key in ("yield_strength", "hardness"):
                if getattr(self, key) != math.inf:
                    raise InputError(f"{label}.{key}", f"a rigid body (E = inf) neither yields nor indents, got "
                                                       f"{getattr(self, key)!r}; leave it inf (Material.rigid())")
            return
        if isinstance(self.nu, bool) or not (isinstance(self.nu, (int, float)) and math.isfinite(self.nu)
                                             and -1.0 < self.nu <= 0.5):
            raise InputError(f"{label}.nu", f"must lie in (-1, 0.5], got {self.nu!r}")
        _check_positive(f"{label}.yield_strength", self.yield_strength, allow_inf=True)
        _check_positive(f"{label}.hardness", self.hardness, allow_inf=True)

    @classmethod
    def rigid(cls, name: str = "") -> Material:
        """A rigid body: E = inf, no Poisson ratio (None), no yield strength or hardness (inf)."""
        return cls(math.inf, None, name=name)

    @property
    def is_rigid(self) -> bool:
        """True for a rigid body (E = inf)."""
        return self.E == math.inf

    @property
    def G(self) -> float:
        """Shear modulus G = E / (2 (1 + nu)) [Pa]; inf for a rigid body."""
        return math.inf if self.is_rigid else self.E / (2.0 * (1.0 + self.nu))


def _check_positive(key: str, value, allow_inf: bool = False):
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise InputError(key, f"must be a number, got {value!r}")
    if math.isnan(value) or (math.isinf(value) and not allow_inf) or value <= 0.0:
        raise InputError(key, f"must be a positive finite number, got {value!r}")


@dataclass(frozen=True)
class MaterialPair:
    """Composite constants of the sphere (body 1) on the flat (body 2).

    Either body may be rigid (``Material.rigid()``), not both: each constant is then its limit
    E -> inf, the rigid body's compliance terms dropped (``compliance``), so a rigid sphere on an
    elastic flat has 1/E* = (1 - nu2^2)/E2 and D = -(1 - 2 nu2)/G2.

    Attributes:
        sphere: material of body 1.
        flat: material of body 2.
    """

    sphere: Material
    flat: Material

    def __post_init__(self):
        if self.sphere.is_rigid and self.flat.is_rigid:
            raise InputError(f"{self.flat.name or 'flat'}.rigid",
                             f"cannot be true with {self.sphere.name or 'sphere'}.rigid = true: two rigid bodies do "
                             "not deform, so there is no contact problem to solve; make one of them elastic (E, nu)")

    @staticmethod
    def compliance(m: Material, per_body) -> float:
        """``per_body(m)``, one body's term of a composite compliance [1/Pa]; 0 for a rigid body
        (each term is a compliance over E or G, whose limit E -> inf is 0)."""
        return 0.0 if m.is_rigid else per_body(m)

    def _sum(self, per_body) -> float:
        """``per_body(sphere) + per_body(flat)``: the two half-spaces' compliances add (in series)."""
        return self.compliance(self.sphere, per_body) + self.compliance(self.flat, per_body)

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
        """Normal-tangential coupling D = (1 - 2 nu1)/G1 - (1 - 2 nu2)/G2 [1/Pa]; 0 for identical
        bodies, and for a rigid body on an incompressible one (nu = 0.5)."""
        def per_body(m):
            return (1.0 - 2.0 * m.nu) / m.G

        return self.compliance(self.sphere, per_body) - self.compliance(self.flat, per_body)

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
        """The material of lower yield strength (it sets the von Mises shear limit and the hardness
        cap), the sphere where they tie; a rigid body is never the softer."""
        return min((m for m in (self.sphere, self.flat) if not m.is_rigid), key=lambda m: m.yield_strength)

    @property
    def elastic(self) -> dict:
        """The bodies that deform, by role: "sphere", "flat" -> Material (a rigid body left out)."""
        return {role: m for role, m in (("sphere", self.sphere), ("flat", self.flat)) if not m.is_rigid}


#: The paper's Table 1: copper asperity.
COPPER = Material(E=106e9, nu=0.33, yield_strength=200e6, hardness=1.0e9, name="copper")
#: The paper's Table 1: hardened steel flat.
HARDENED_STEEL = Material(E=205e9, nu=0.31, yield_strength=345e6, hardness=6.2e9, name="hardened steel")
#: The paper's pair: copper sphere (R = 10 um) on a hardened steel flat.
PAPER_PAIR = MaterialPair(COPPER, HARDENED_STEEL)
