"""Surface grid and the gap before deformation: a sphere, paraboloid, flat punch, cone or height map
on a flat, which may carry a height map of its own (MODEL.md sections 2 and 3)."""

from __future__ import annotations

import hashlib
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


#: The shapes body 1 may have (``[sphere] profile``).
PROFILES = ("sphere", "paraboloid", "flat_punch", "cone", "height_map")
#: The profiles whose gap near the first point of contact is r^2 / 2R: Hertz's closed forms
#: (contact radius, force, Mindlin, the adhesion maps) describe them, and no other.
HERTZIAN = ("sphere", "paraboloid")


class HeightMap:
    """A surface given as heights on a grid of square pixels: the gap a body adds before deformation.

    The first array axis runs along x, the second along y (``heights[i, j]`` is the height at x_i,
    y_j); the map is centred on the grid's centre, the first point of contact, with its values
    taken at the centres of its pixels (x_i = (i - (nx - 1) / 2) pixel_size), so a map of the
    grid's own cells is the grid's gap as it is. Heights are shifted so that the lowest is 0, and
    are positive away from the other body.

    Attributes:
        heights: heights [m], shape (nx, ny), float64, lowest 0.
        pixel_size: side of a pixel [m].
        source: where the map came from (a file path, or a name), for messages and records.
        key: the case-file table the map belongs to ("sphere" or "flat"), for messages.
        height_unit: the unit the file's heights were read in (recorded, the heights are in m).
    """

    def __init__(self, heights, pixel_size: float, source: str = "", key: str = "sphere", height_unit: str = "m"):
        h = np.array(heights, dtype=np.float64)
        if h.ndim != 2 or min(h.shape) < 2:
            raise InputError(f"{key}.height_map", f"must be a 2-D grid of at least 2 x 2 heights, got shape {h.shape}")
        if not np.isfinite(h).all():
            bad = int(np.count_nonzero(~np.isfinite(h)))
            raise InputError(f"{key}.height_map", f"holds {bad} value(s) that are not finite numbers (NaN or inf); "
                                                  "fill the missing points before using the map")
        p = pixel_size
        if isinstance(p, bool) or not isinstance(p, (int, float)) or not math.isfinite(p) or p <= 0:
            raise InputError(f"{key}.pixel_size", f"must be a positive finite length in m, got {p!r}")
        self.heights = h - h.min()
        self.heights.setflags(write=False)
        self.pixel_size = float(p)
        self.source, self.key, self.height_unit = str(source), key, height_unit
        self._digest = hashlib.sha1(self.heights.tobytes()).hexdigest()

    def _identity(self):
        return (self.heights.shape, self.pixel_size, self._digest)

    def __eq__(self, other):
        return isinstance(other, HeightMap) and self._identity() == other._identity()

    def __hash__(self):
        return hash(self._identity())

    def __repr__(self):
        nx, ny = self.heights.shape
        return f"HeightMap({self.source!r}, {nx} x {ny} pixels of {self.pixel_size:g} m)"

    @property
    def extent(self) -> tuple[float, float]:
        """The map's sides along x and y [m]: pixels times pixel_size."""
        return self.heights.shape[0] * self.pixel_size, self.heights.shape[1] * self.pixel_size

    def check_covers(self, grid: "Grid") -> None:
        """Raise InputError("<key>.height_map", ...) where the grid's domain reaches outside the map."""
        lx, ly = self.extent
        if grid.size > min(lx, ly) * (1.0 + 1e-12):
            nx, ny = self.heights.shape
            raise InputError(f"{self.key}.height_map",
                             f"covers {lx:.4g} m x {ly:.4g} m ({nx} x {ny} pixels of {self.pixel_size:.4g} m), less "
                             f"than the domain (grid.size = {grid.size:.4g} m); use grid.size <= {min(lx, ly):.4g} m "
                             "or a larger map")

    def sample(self, grid: "Grid") -> np.ndarray:
        """The map's heights [m] at the grid's cell centres, shape (n, n), indexed [row = y,
        column = x]: bilinear interpolation between the four nearest pixel centres
        (``scipy.ndimage.map_coordinates``, order 1: exact at pixel centres, no overshoot),
        the outermost pixels' values held over the half pixel beyond their centres."""
        from scipy.ndimage import map_coordinates

        self.check_covers(grid)
        nx, ny = self.heights.shape
        ix = grid.x / self.pixel_size + 0.5 * (nx - 1)
        iy = grid.y / self.pixel_size + 0.5 * (ny - 1)
        IX, IY = np.meshgrid(ix, iy, indexing="xy")  # [row = y, column = x]
        return map_coordinates(self.heights, [IX, IY], order=1, mode="nearest")

    def unresolved_relief(self, grid: "Grid") -> float:
        """The rms of the map's relief the grid leaves out [m]: the map's pixels inside the domain
        less the bilinear interpolation of the heights the grid reads at its cell centres (``sample``);
        0 where the cells are no coarser than the pixels. Smooth shapes leave out little (a sphere
        of radius R about dx^2 / 8R), rough maps their wavelengths under two cells."""
        from scipy.ndimage import map_coordinates

        if grid.dx <= self.pixel_size * (1.0 + 1e-9):
            return 0.0
        nx, ny = self.heights.shape
        # the pixels inside the domain, between the outermost cell centres
        half = 0.5 * (grid.n - 1) * grid.dx
        ix = np.arange(nx)[np.abs((np.arange(nx) - 0.5 * (nx - 1)) * self.pixel_size) <= half]
        iy = np.arange(ny)[np.abs((np.arange(ny) - 0.5 * (ny - 1)) * self.pixel_size) <= half]
        read = self.sample(grid)  # [row = y, column = x]
        cx = ((ix - 0.5 * (nx - 1)) * self.pixel_size + half) / grid.dx  # the pixels in cell-centre units
        cy = ((iy - 0.5 * (ny - 1)) * self.pixel_size + half) / grid.dx
        CX, CY = np.meshgrid(cx, cy, indexing="ij")  # [x, y] as the map's axes
        back = map_coordinates(read, [CY, CX], order=1, mode="nearest")
        return float(np.sqrt(np.mean((self.heights[np.ix_(ix, iy)] - back) ** 2)))

    @property
    def curvature_radius(self) -> float:
        """1 / mean curvature [m] at the map's lowest pixel (five-point Laplacian); inf where it is
        flat or on the map's edge. A scale for the adhesion regime (Maugis's parameter), no more."""
        h, p = self.heights, self.pixel_size
        i, j = np.unravel_index(int(np.argmin(h)), h.shape)
        if not (0 < i < h.shape[0] - 1 and 0 < j < h.shape[1] - 1):
            return math.inf
        lap = (h[i + 1, j] + h[i - 1, j] + h[i, j + 1] + h[i, j - 1] - 4.0 * h[i, j]) / (p * p)
        return 2.0 / lap if lap > 0.0 else math.inf


def _length(key: str, v, *, zero: bool = False) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not (v >= 0 if zero else v > 0):
        raise InputError(key, f"must be a {'non-negative' if zero else 'positive'} finite length in m, got {v!r}")
    return float(v)


@dataclass(frozen=True)
class Sphere:
    """Body 1's shape over the flat (the asperity), rigidly moved: the gap before deformation.

    Profiles (h0: the gap at distance r from the axis, 0 at the first point of contact):

    - "sphere": R - sqrt(R^2 - r^2); "paraboloid": r^2 / (2 R) (R = ``radius``);
    - "flat_punch": a cylinder of radius a = ``radius`` with a flat end, its edge rounded with
      radius rho = ``edge_radius`` (0: sharp): 0 for r <= a - rho, rho - sqrt(rho^2 - (r - a +
      rho)^2) on the rounded edge, and a wall ``PUNCH_WALL_IN_RADII`` a high beyond r = a;
    - "cone": semi-angle alpha = ``half_angle`` (degrees between the axis and the surface), its
      tip rounded by a sphere of radius rho = ``tip_radius`` (0: sharp) that meets the cone
      tangentially at r_t = rho cos(alpha): r / tan(alpha) when sharp, else rho - sqrt(rho^2 -
      r^2) for r <= r_t and (r - r_t) / tan(alpha) + rho (1 - sin(alpha)) beyond;
    - "height_map": a measured or synthetic surface (``HeightMap``).

    ``flat_map``, the flat's own height map where it has one, adds its heights: the gap is the sum.

    Attributes:
        radius: R [m] of "sphere" and "paraboloid"; the punch's radius a [m]; for the cone and a
            height map, set from the others: the radius of curvature at the first point of contact
            (``curvature_radius``), the length Maugis's adhesion parameter takes.
        profile: one of ``PROFILES``.
        edge_radius: the punch's edge radius rho [m], 0 <= rho <= a (0: a sharp edge).
        half_angle: the cone's semi-angle alpha [degrees], 0 < alpha < 90.
        tip_radius: the cone's tip radius [m], >= 0 (0: a sharp tip).
        height_map: body 1's ``HeightMap`` (profile "height_map").
        flat_map: the flat's ``HeightMap``, or None.
    """

    radius: float | None = None
    profile: str = "sphere"
    edge_radius: float = 0.0
    half_angle: float | None = None
    tip_radius: float = 0.0
    height_map: HeightMap | None = None
    flat_map: HeightMap | None = None

    def __post_init__(self):
        if self.profile not in PROFILES:
            raise InputError("sphere.profile", f"must be one of {', '.join(map(repr, PROFILES))}, got {self.profile!r}")
        if self.profile in HERTZIAN or self.profile == "flat_punch":
            object.__setattr__(self, "radius", _length("sphere.radius", self.radius))
        object.__setattr__(self, "edge_radius", _length("sphere.edge_radius", self.edge_radius, zero=True))
        object.__setattr__(self, "tip_radius", _length("sphere.tip_radius", self.tip_radius, zero=True))
        if self.profile == "flat_punch" and self.edge_radius > self.radius:
            raise InputError("sphere.edge_radius", f"must not exceed the punch's radius {self.radius:g} m, got "
                                                   f"{self.edge_radius:g} m")
        if self.profile == "cone":
            a = self.half_angle
            if isinstance(a, bool) or not isinstance(a, (int, float)) or not 0.0 < a < 90.0:
                raise InputError("sphere.half_angle", f"must be an angle in degrees between 0 and 90 (exclusive), "
                                                      f"got {a!r}")
            object.__setattr__(self, "half_angle", float(a))
        if self.profile == "height_map" and not isinstance(self.height_map, HeightMap):
            raise InputError("sphere.height_map", "is required for profile 'height_map'")
        if self.profile in ("cone", "height_map"):  # no radius of its own: the tip's curvature radius
            object.__setattr__(self, "radius", self.tip_radius if self.profile == "cone"
                               else self.height_map.curvature_radius)

    @property
    def hertzian(self) -> bool:
        """True where Hertz's closed forms describe the shape (a sphere or paraboloid on a flat
        flat): the profile is one of ``HERTZIAN`` and the flat has no height map."""
        return self.profile in HERTZIAN and self.flat_map is None

    @property
    def fills_domain(self) -> bool:
        """True where the body is its height map over the domain, with nothing beyond it (profile
        "height_map"): its contact and adhesion may reach the domain's edge, which cuts nothing."""
        return self.profile == "height_map"

    @property
    def description(self) -> str:
        """The shape in words, for messages: "a sphere", "a cone", "a paraboloid on a flat with a height map"."""
        name = {"flat_punch": "a flat punch", "height_map": "a height map"}.get(self.profile, f"a {self.profile}")
        return name + (" on a flat with a height map" if self.flat_map is not None else "")

    @property
    def curvature_radius(self) -> float:
        """Radius of curvature [m] at the first point of contact, for the adhesion regime
        (Maugis's parameter): R; inf for the punch's flat end; the cone's tip radius (0 when
        sharp); the height map's (``HeightMap.curvature_radius``)."""
        if self.profile in HERTZIAN:
            return self.radius
        if self.profile == "flat_punch":
            return math.inf
        if self.profile == "cone":
            return self.tip_radius
        return self.height_map.curvature_radius

    def contact_radius(self, delta_z: float) -> float | None:
        """The contact radius [m] the rigid-body theory gives at approach ``delta_z`` [m] (0 for
        delta_z <= 0): Hertz's sqrt(R delta_z); the punch's radius; the sharp cone's 2 delta_z
        tan(alpha) / pi (Love 1939; a rounded tip's is smaller); None for a height map."""
        if not delta_z > 0.0:
            return 0.0
        if self.profile in HERTZIAN:
            return math.sqrt(self.radius * delta_z)
        if self.profile == "flat_punch":
            return self.radius
        if self.profile == "cone":
            return 2.0 * delta_z * math.tan(math.radians(self.half_angle)) / math.pi
        return None

    def gap_radius(self, gap: float) -> float | None:
        """The radius [m] within which the rigid profile's gap stays under ``gap`` [m] (an upper
        bound): sqrt(2 R gap) (the paraboloid), the punch's radius, the sharp cone's gap tan(alpha);
        None for a height map."""
        gap = max(0.0, gap)
        if self.profile in HERTZIAN:
            return math.sqrt(2.0 * self.radius * gap)
        if self.profile == "flat_punch":
            return self.radius
        if self.profile == "cone":
            return gap * math.tan(math.radians(self.half_angle))
        return None

    def check_domain(self, grid: Grid):
        """Raise InputError where the gap does not exist on the grid: "grid.size" where a cell
        centre of the exact sphere lies at r >= R, "<table>.height_map" where the domain reaches
        outside a height map."""
        for m in (self.height_map, self.flat_map):
            if m is not None:
                m.check_covers(grid)
        if self.profile != "sphere":
            return
        corner = 0.5 * (grid.n - 1) * grid.dx  # the farthest cell centre's |x| and |y|
        if corner * corner + corner * corner >= self.radius**2:
            raise InputError(
                "grid.size",
                f"the domain ({grid.size:g} m across) reaches beyond the sphere's radius {self.radius:g} m",
            )

    def initial_gap(self, grid: Grid) -> np.ndarray:
        """Gap before deformation h0(x, y) [m] at the cell centres, shape (n, n), float64 (on
        CUDA the model makes a sphere's or paraboloid's on the device: ``kernels/geometry.py``)."""
        self.check_domain(grid)
        if self.profile == "height_map":
            h = self.height_map.sample(grid)
        else:
            X, Y = grid.mesh()
            h = self._axisymmetric(X**2 + Y**2)
        if self.flat_map is not None:
            h = h + self.flat_map.sample(grid)
        return h

    def _axisymmetric(self, r2: np.ndarray) -> np.ndarray:
        """h0 [m] of an axisymmetric profile at squared distances ``r2`` [m^2] from the axis."""
        if self.profile == "paraboloid":
            return r2 / (2.0 * self.radius)
        if self.profile == "sphere":
            return r2 / (self.radius + np.sqrt(self.radius**2 - r2))  # = R - sqrt(R^2 - r^2), no cancellation
        r = np.sqrt(r2)
        if self.profile == "flat_punch":
            a, rho = self.radius, self.edge_radius
            s = np.clip(r - (a - rho), 0.0, rho)  # how far into the rounded edge
            edge = s * s / (rho + np.sqrt(np.maximum(rho * rho - s * s, 0.0))) if rho > 0.0 else 0.0 * r
            return np.where(r <= a, edge, PUNCH_WALL_IN_RADII * a)
        alpha = math.radians(self.half_angle)
        rho = self.tip_radius
        rt = rho * math.cos(alpha)
        cone = (r - rt) / math.tan(alpha) + rho * (1.0 - math.sin(alpha))
        if rho == 0.0:
            return cone
        cap = r2 / (rho + np.sqrt(np.maximum(rho * rho - r2, 0.0)))
        return np.where(r <= rt, cap, cone)


#: The height of the flat punch's side [punch radii]: the gap beyond its edge. The half-space
#: model needs approaches far below it (``Case`` refuses delta_z of a tenth of it or more).
PUNCH_WALL_IN_RADII = 1.0


def profile_note(size: float, sphere) -> str:
    """What a suggested domain side [m] needs of the profile: "" when it fits the sphere's profile,
    else a clause asking for the paraboloid (the exact sphere's gap exists only within r < R, so
    its domain stays below sqrt(2) R)."""
    if getattr(sphere, "profile", "sphere") != "sphere" or size < math.sqrt(2.0) * sphere.radius:
        return ""
    return (f" with sphere.profile = 'paraboloid' (a domain of that side reaches beyond the sphere's radius "
            f"R = {sphere.radius:.4g} m)")
