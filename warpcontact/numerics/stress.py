"""The stress below the surface, in both bodies, from the solved surface tractions.

Each body is an elastic half-space (the half-space approximation of the contact model) with its
own Poisson ratio, loaded on its surface by the tractions of the solved state, piecewise constant
on the cells: the pressure p (elastic and adhesive parts, compressive positive) and the shear
(elastic and adhesive). The flat carries (p, q_x, q_y), q the shear the sphere exerts on it; the
sphere carries (p, -q_x, -q_y). Stresses are given in each body's own frame: x, y those of the
grid, z the depth into that body (positive; upwards in the sphere), so that sigma_xz and
sigma_yz of the sphere are the negatives of their values in the flat's frame turned upside down;
invariants (von Mises, principal stresses) do not depend on the frame. Tension positive.

Formulas. Love's potential representation of the Boussinesq-Cerruti problem (Johnson 1985,
Contact Mechanics, section 3.1, eqs. 3.2-3.7): with Omega = z ln(rho + z) - rho and Phi the
integral of Omega against one traction component, the displacements are

* pressure: u_x = [(2 nu - 1) Phi_xz - z Phi_xzz] / (4 pi G), u_y likewise,
  u_z = [2 (1 - nu) Phi_zz - z Phi_zzz] / (4 pi G);
* shear q_x: u_x = [2 Phi_zz + 2 nu Phi_xx - z Phi_xxz] / (4 pi G),
  u_y = [2 nu Phi_xy - z Phi_xyz] / (4 pi G), u_z = [(1 - 2 nu) Phi_xz - z Phi_xzz] / (4 pi G);

and Hooke's law gives the stresses as sums of third derivatives of Phi and z times fourth
derivatives, independent of G. Omega is harmonic, so every z derivative beyond the first can be
traded for x and y derivatives; the stresses of the three tractions then use 14 derivatives of
Omega (``BASIS``), combined with coefficients in nu and z (``stress_table``). A uniform traction on
a rectangle integrates each derivative in closed form: with C(x, y) an antiderivative such that
d^2 C / dx dy equals it, the integral is C summed over the rectangle's corners with signs. The
14 antiderivatives (``kernels/stress.py``, ``corner_term``) are elementary (logarithms, arctangents,
rational functions of rho); for the pressure's sigma_zz they give Love's (1929) rectangle
solution, -(1/2 pi) [atan(x y / (z rho)) + x y z / rho (1/(x^2 + z^2) + 1/(y^2 + z^2))]. The
point-force limits (``stress_reference.boussinesq_point_stress``, Johnson eq. 3.18;
``stress_reference.cerruti_point_stress``, Johnson section 3.5) are the references of the
tests; the derivation was checked symbolically against both.

Convolution. At each depth the 14 basis kernels are evaluated on the n x n quadrant of offsets
(0..n-1, 0..n-1), weighted, and transformed with the project's FFT backend (zero-padded forward
transforms, ``fft.forward``); since each basis kernel is even or odd in x and in y, the spectrum of
the whole kernel on the padded grid (offsets -(n-1)..n-1) follows from the quadrant's spectrum at
(kx, ky) and (kx, -ky) (``kernels/stress.py``, ``stress_spectra``). The stress spectra of a body
are the sums of these kernel spectra times the traction spectra, and six inverse transforms give
its six stress components on the grid: the DC-FFT of Liu, Wang & Liu (2000), exact for piecewise
constant tractions (no periodic images). Per depth: 14 forward transforms shared by the bodies, 6
inverse ones per body. Coefficients are evaluated in float64 whatever the working type (their
corner sums cancel to 1/r^2 of the corner terms' size far from the load).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError

#: stress components, in the order of the kernels' arrays
COMPONENTS = ("sigma_xx", "sigma_yy", "sigma_zz", "sigma_xy", "sigma_xz", "sigma_yz")
#: derived fields: von Mises sqrt(3 J2); tresca, the maximum shear stress (s1 - s3)/2 (the Tresca
#: criterion's equivalent stress is twice it); principal stresses s1 >= s2 >= s3; hydrostatic
#: (mean) stress (s_xx + s_yy + s_zz)/3. All [Pa], tension positive.
DERIVED = ("von_mises", "tresca", "principal_1", "principal_2", "principal_3", "hydrostatic")
FIELDS = COMPONENTS + DERIVED
BODIES = ("sphere", "flat")
#: what a result says of a rigid body (``MaterialPair.elastic`` leaves it out): it has no stress field
RIGID_REASON = "a rigid body has no stress field: not evaluated, not checked for yield"
#: the derivatives of Omega (orders in x, y, z) whose cell integrals make up the stresses
BASIS = ((1, 1, 1), (1, 2, 0), (2, 1, 0), (1, 2, 1), (2, 1, 1), (1, 1, 2), (2, 0, 1), (0, 2, 1), (2, 0, 2),
         (0, 2, 2), (1, 0, 2), (0, 1, 2), (1, 0, 3), (0, 1, 3))
#: parity of each basis kernel: 0 even in x and y, 1 odd in x, 2 odd in y, 3 odd in both
BASIS_PARITY = tuple((a % 2) + 2 * (b % 2) for a, b, _ in BASIS)
#: default number of depths and the deepest one in contact radii (``default_depths``)
DEFAULT_LAYERS = 32
DEFAULT_MAX_DEPTH_IN_A = 2.0
#: the depth that stands for the surface, in cells: the stress of cell-wise constant tractions at
#: z -> 0 is finite at the cell centres, and rises steeply within the first cell's depth (under
#: k_tau = 0.95 sliding, n = 64: von Mises 1.143e8 Pa at 0.43 dx, 1.272e8 at 0.21 dx, 1.5646e8 at
#: 1e-5 dx); at 1e-3 dx it is within 0.12 % of the limit (1.5627e8), in float64 and float32 alike
SURFACE_DEPTH_IN_CELLS = 1e-3


def stress_table(nu: float, z: float) -> np.ndarray:
    """Coefficients T[c, l, b]: stress component c (COMPONENTS) per unit traction l (p, q_x, q_y)
    = sum over b of T[c, l, b] times the cell integral of basis kernel b (BASIS), at depth z [cells].

    From Love's potentials (module docstring), after Hooke's law and the reduction by Omega's
    harmonicity; all entries carry 1/(2 pi). With B_b the basis integrals:
    p:   xx = -B6 - 2nu B7 - z B8;  yy = -2nu B6 - B7 - z B9;  zz = -B6 - B7 + z (B8 + B9);
         xy = (2nu - 1) B0 - z B5;  xz = -z B12;  yz = -z B13.
    q_x: xx = -2nu B1 + 2 B10 + z (B3 + B12);  yy = 2nu (B1 + B10) - z B3;  zz = -z B12;
         xy = 2nu B2 + B11 - z B4;  xz = -B6 - B7 - z B8;  yz = -z B5.
    q_y: the q_x entries with x and y exchanged.
    """
    t = np.zeros((6, 3, len(BASIS)))
    XX, YY, ZZ, XY, XZ, YZ = range(6)
    P, QX, QY = range(3)
    n2 = 2.0 * nu
    t[XX, P, [6, 7, 8]] = (-1.0, -n2, -z)
    t[YY, P, [6, 7, 9]] = (-n2, -1.0, -z)
    t[ZZ, P, [6, 7, 8, 9]] = (-1.0, -1.0, z, z)
    t[XY, P, [0, 5]] = (n2 - 1.0, -z)
    t[XZ, P, 12] = -z
    t[YZ, P, 13] = -z
    t[XX, QX, [1, 10, 3, 12]] = (-n2, 2.0, z, z)
    t[YY, QX, [1, 10, 3]] = (n2, n2, -z)
    t[ZZ, QX, 12] = -z
    t[XY, QX, [2, 11, 4]] = (n2, 1.0, -z)
    t[XZ, QX, [6, 7, 8]] = (-1.0, -1.0, -z)
    t[YZ, QX, 5] = -z
    # q_y: x <-> y. Basis pairs exchanged by the swap, and components.
    swap_b = {0: 0, 1: 2, 2: 1, 3: 4, 4: 3, 5: 5, 6: 7, 7: 6, 8: 9, 9: 8, 10: 11, 11: 10, 12: 13, 13: 12}
    swap_c = {XX: YY, YY: XX, ZZ: ZZ, XY: XY, XZ: YZ, YZ: XZ}
    for c in range(6):
        for b in range(len(BASIS)):
            t[swap_c[c], QY, swap_b[b]] = t[c, QX, b]
    return t / (2.0 * np.pi)


def cell_kernels(nu: float, z_cells: float, size: int, device="cpu") -> np.ndarray:
    """K[c, l, i, j]: stress component c per unit traction l (p, q_x, q_y) on one cell, at the
    offset (x, y) = (j, i) cells (0 <= i, j < ``size``) from it and depth ``z_cells`` [cells],
    float64 (the basis integrals of ``kernels/stress.py`` combined by ``stress_table``; negative
    offsets follow from BASIS_PARITY). For tests and direct sums."""
    import warp as wp

    from warpcontact.kernels import stress as ks

    basis = np.empty((len(BASIS), size, size))
    corners = wp.zeros((size + 1, size + 1), dtype=wp.float64, device=device)
    out = wp.zeros((size, size), dtype=wp.float64, device=device)
    for b in range(len(BASIS)):
        wp.launch(ks.basis_corners, dim=(size + 1, size + 1), inputs=[b, wp.float64(z_cells), 0], outputs=[corners],
                  device=device)
        wp.launch(ks.basis_quadrant, dim=(size, size), inputs=[corners, 0, 0], outputs=[out], device=device)
        basis[b] = out.numpy()
    return np.einsum("clb,bij->clij", stress_table(nu, z_cells), basis)


#: the bases each load's stresses use (p, q_x, q_y): the columns of ``stress_table`` with a
#: non-zero entry (at any nu < 1/2 and z > 0; a pressure alone uses 8 of the 14)
LOAD_BASES = tuple(tuple(int(b) for b in np.flatnonzero(stress_table(0.3, 1.0)[:, load].any(axis=0)))
                   for load in range(3))


def used_bases(loads) -> list[int]:
    """The bases the stresses of the loaded tractions use (``loads``: p, q_x, q_y), in order."""
    return sorted({b for on, bases in zip(loads, LOAD_BASES) if on for b in bases})


def body_coefficients(nu: float, sphere: bool, z_cells: float, loads, scale: float = 1.0) -> tuple:
    """The arguments of ``kernels/stress.py``'s ``body_stress_spectra`` for one body at depth
    ``z_cells``: (2 nu, z, p_scale, qx_scale, qy_scale), the tractions' scales ``scale`` / (2 pi)
    (the stress table's factor), the sphere's shear negated (it carries -q), zero for a load not
    in ``loads`` (p, q_x, q_y)."""
    s = scale / (2.0 * math.pi)
    q = -s if sphere else s
    return (2.0 * nu, float(z_cells), *(v if on else 0.0 for v, on in zip((s, q, q), loads)))


#: ``stress_spectra``'s work an entry in elementwise passes' (``SubsurfaceStress._rows``): it reads
#: 31 complex numbers and writes 6 (n = 1024, one CPU thread: about 110 ms a body, against about
#: 15 ms for a pass that reads one field and writes one)
STRESS_SPECTRA_WORK = 8


# ---------------------------------------------------------------------------------------------
# Memory.


def memory_bytes(n: int, dtype, fft: str, depths: int, volume: bool = False) -> dict:
    """Bytes of one subsurface-stress evaluation on an n x n grid: ``device`` (the arrays of
    ``SubsurfaceStress``: 23 spectra (14 basis, 3 traction, 6 stress), 13 (n, n) fields (one work
    field, 6 stress components, 6 derived fields), the FFT backend's buffers, about 2 spectra and
    4 fields) and ``host`` (the sections, and with ``volume`` the 12 fields of every depth of both
    bodies in float64)."""
    from .device import resolve_dtype
    from .resources import spectral_entries

    real = 8 if resolve_dtype(dtype).__name__ == "float64" else 4
    spectrum = spectral_entries(n, fft) * 2 * real
    device = (23 + 2) * spectrum + (13 + 4) * n * n * real
    host = 2 * len(FIELDS) * depths * n * 8
    if volume:
        host += 2 * len(FIELDS) * depths * n * n * 8
    return {"device": int(device), "host": int(host)}


def check_memory(n: int, dtype, device, fft: str, depths: int, volume: bool = False) -> dict:
    """Raise InputError("grid.n", ...) when the evaluation does not fit in the memory of
    ``device`` (and, on CUDA, the host's for what is copied back), naming the largest n that fits;
    returns ``memory_bytes``."""
    import warp as wp

    from .resources import GIB, _resolve_fft, host_memory_bytes, memory_limit

    dev = wp.get_device(device)
    kind = "cpu" if dev.is_cpu else "cuda"
    fft_name = _resolve_fft(fft, kind)
    limit, what = memory_limit(dev)
    host_limit = host_memory_bytes()

    def need(m):
        b = memory_bytes(m, dtype, fft_name, depths, volume)
        if kind == "cpu":
            return b["device"] + b["host"], b["device"] + b["host"] <= (limit or math.inf)
        return b["device"], b["device"] <= (limit or math.inf) and b["host"] <= (host_limit or math.inf)

    total, fits = need(n)
    if fits:
        return memory_bytes(n, dtype, fft_name, depths, volume)
    lo, hi = 0, n
    while hi - lo > 1:
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if need(mid)[1] else (lo, mid)
    dname = dtype if isinstance(dtype, str) else dtype.__name__
    extra = ", every depth's fields kept (volume)" if volume else ""
    raise InputError("grid.n", f"the subsurface stress at n = {n} with {depths} depths needs about "
                               f"{total / GIB:,.2f} GiB ({dname}, {fft_name} FFT{extra}) but the {what} is "
                               f"{limit / GIB:,.2f} GiB; the largest grid that fits is n = {lo}")


# ---------------------------------------------------------------------------------------------
# The evaluation.


@dataclass
class BodyStress:
    """The stress in one body (SI: Pa, m).

    Attributes:
        name: "sphere" or "flat".
        nu: its Poisson ratio; yield_strength: S_Y [Pa] (inf when not given).
        section: FIELDS -> (n_depths, n) along the section line (``StressResult.section_axis``)
            through the grid's centre.
        axis: FIELDS -> (n_depths,) at the cell nearest the centre.
        depth_max: "von_mises", "tresca" -> (n_depths, 3): the largest value at each depth and its
            x, y [m].
        volume: FIELDS -> (n_depths, n, n), when kept.
    """

    name: str
    nu: float
    yield_strength: float
    section: dict = field(default_factory=dict)
    axis: dict = field(default_factory=dict)
    depth_max: dict = field(default_factory=dict)
    volume: dict | None = None

    def maximum(self, name: str, depths: np.ndarray) -> dict:
        """The largest ``name`` ("von_mises" or "tresca") over the depths: ``value`` [Pa] and its
        ``x``, ``y``, ``z`` [m], z refined between depths by the parabola through the largest
        per-depth value and its two neighbours (``value_on_grid``, ``z_on_grid``: the largest
        value at a computed depth and that depth)."""
        return depth_maximum(self.depth_max[name], depths)


def depth_maximum(m: np.ndarray, depths: np.ndarray) -> dict:
    """The largest of per-depth maxima ``m`` ((n_depths, 3): value, x, y) over increasing
    ``depths``: ``value`` and its ``x``, ``y``, ``z`` [m], z refined between depths by the parabola
    through the largest per-depth value and its two neighbours (``value_on_grid``, ``z_on_grid``:
    the largest value at a computed depth and that depth)."""
    k = int(np.argmax(m[:, 0]))
    out = {"value": float(m[k, 0]), "x": float(m[k, 1]), "y": float(m[k, 2]), "z": float(depths[k]),
           "value_on_grid": float(m[k, 0]), "z_on_grid": float(depths[k])}
    if 0 < k < len(depths) - 1:
        z0, z1, z2 = depths[k - 1:k + 2]
        v0, v1, v2 = m[k - 1:k + 2, 0]
        # vertex of the parabola through the three points (Newton's divided differences)
        d1, d2 = (v1 - v0) / (z1 - z0), (v2 - v1) / (z2 - z1)
        curv = (d2 - d1) / (z2 - z0)
        if curv < 0:
            zv = 0.5 * (z0 + z1) - d1 / (2.0 * curv)
            zv = min(max(zv, z0), z2)
            out["z"] = float(zv)
            out["value"] = float(v0 + d1 * (zv - z0) + curv * (zv - z0) * (zv - z1))
    return out


@dataclass
class StressResult:
    """The subsurface stress of one solved state in both bodies.

    Attributes:
        depths: (n_depths,) [m], increasing, each body's depth below its surface.
        x, y: cell centres [m].
        section_axis: "x" (the section runs along x through the centre row) or "y".
        section_index: the row (x) or column (y) of the section; axis_index: the cell (row,
            column) of the depth profiles.
        bodies: "sphere", "flat" -> :class:`BodyStress`, the elastic bodies (a rigid one has none).
        elapsed_s: wall time of the evaluation; device, dtype, fft: where and how.
        rigid: the rigid bodies' names ("sphere" or "flat"; empty for two elastic bodies).
    """

    depths: np.ndarray
    x: np.ndarray
    y: np.ndarray
    section_axis: str
    section_index: int
    axis_index: tuple
    bodies: dict
    elapsed_s: float = 0.0
    device: str = ""
    dtype: str = ""
    fft: str = ""
    #: the state of the path (``subsurface_stress``): its index, approach {x, y, z} [m], convergence
    state_index: int | None = None
    delta: dict | None = None
    converged: bool = True
    #: per body, ``first_yield``'s answer over the states up to this one (empty when not asked)
    first_yield: dict = field(default_factory=dict)
    rigid: tuple = ()

    def summary(self) -> dict:
        """stress.json's per-body part: von_mises_max and tresca_max (value [Pa], x, y, z [m], z the
        depth into the body), yield_strength [Pa] or None, yielded, margin = S_Y / von Mises max; a
        rigid body: ``rigid`` true, ``yielded`` None and the ``reason``."""
        out = {name: {"rigid": True, "yielded": None, "reason": RIGID_REASON} for name in self.rigid}
        for name, b in self.bodies.items():
            vm = b.maximum("von_mises", self.depths)
            sy = b.yield_strength
            out[name] = {
                "nu": b.nu,
                "von_mises_max": vm,
                "tresca_max": b.maximum("tresca", self.depths),
                "yield_strength": sy if math.isfinite(sy) else None,
                "yielded": bool(math.isfinite(sy) and vm["value"] >= sy),
                "margin": sy / vm["value"] if math.isfinite(sy) and vm["value"] > 0 else None,
            }
            if name in self.first_yield:
                out[name]["first_yield"] = self.first_yield[name]
        return out

    def arrays(self) -> dict:
        """stress.npz: ``depths``, ``x``, ``y`` [m]; per body B and field F (FIELDS) ``B_section_F``
        (n_depths, n), ``B_axis_F`` (n_depths,), ``B_F`` (n_depths, n, n) when kept, and
        ``B_depth_max_von_mises`` / ``_tresca`` (n_depths, 3: value [Pa], x, y [m])."""
        out = {"depths": self.depths, "x": self.x, "y": self.y,
               "section_index": np.int64(self.section_index), "axis_index": np.array(self.axis_index)}
        for name, b in self.bodies.items():
            for f in FIELDS:
                out[f"{name}_section_{f}"] = b.section[f]
                out[f"{name}_axis_{f}"] = b.axis[f]
                if b.volume is not None:
                    out[f"{name}_{f}"] = b.volume[f]
            for f, m in b.depth_max.items():
                out[f"{name}_depth_max_{f}"] = m
        return out


def check_depths(depths) -> np.ndarray:
    """Depths [m] as an increasing float64 array; InputError("depths", ...) unless finite and > 0."""
    try:
        d = np.asarray(depths, dtype=np.float64).ravel()
    except (TypeError, ValueError):
        raise InputError("depths", f"must be numbers [m], got {depths!r}") from None
    if d.size == 0:
        raise InputError("depths", "needs at least one depth")
    if not np.all(np.isfinite(d)) or np.any(d <= 0):
        raise InputError("depths", f"must be finite and positive (below the surface) [m], got {d.tolist()}")
    return np.unique(d)


def default_depths(contact_radius: float, dx: float, layers: int = DEFAULT_LAYERS,
                   max_depth: float | None = None) -> np.ndarray:
    """The surface (``SURFACE_DEPTH_IN_CELLS`` cells: where the largest von Mises stress lies
    under sliding friction) and ``layers`` equally spaced depths from max_depth/layers to
    ``max_depth`` (default DEFAULT_MAX_DEPTH_IN_A contact radii, or 16 cells without contact) [m]."""
    if isinstance(layers, bool) or not isinstance(layers, (int, np.integer)) or layers < 1:
        raise InputError("layers", f"must be a positive integer, got {layers!r}")
    if max_depth is None:
        max_depth = DEFAULT_MAX_DEPTH_IN_A * contact_radius if contact_radius > 0 else 16.0 * dx
    return check_depths(np.concatenate([[SURFACE_DEPTH_IN_CELLS * dx],
                                        np.arange(1, layers + 1) * (float(max_depth) / layers)]))


class SubsurfaceStress:
    """Evaluates the stress in each elastic body at a set of depths (module docstring: the method);
    a rigid body has no stress field and is left out (``bodies``).

    Args:
        pair: the materials (sphere: body 1, flat: body 2).
        grid: the surface grid.
        depths: depths below each body's surface [m].
        device, dtype: where and in which float type ("cpu", "cuda"...; "float64", "float32").
        fft: FFT backend name.
        volume: keep every depth's fields (``BodyStress.volume``), not only the sections.

    Buffers are allocated once (``memory_bytes``) and serve every :meth:`evaluate`.
    """

    def __init__(self, pair, grid, depths, device="cpu", dtype="float64", fft="auto", volume: bool = False):
        import warp as wp

        from .device import dtype_name, numpy_dtype, resolve_device, resolve_dtype
        from ..fft import make_fft

        self.pair, self.grid = pair, grid
        #: the bodies evaluated: the elastic ones, in BODIES order
        self.bodies = tuple(pair.elastic)
        self.depths = check_depths(depths)
        self.device = resolve_device(device)
        self.dtype = resolve_dtype(dtype)
        self.dtype_name = dtype_name(self.dtype)
        self.np_dtype = numpy_dtype(self.dtype)
        self.volume = bool(volume)
        n = grid.n
        # the memory first: an evaluation that does not fit is refused before any plan or buffer
        self.memory = check_memory(n, self.dtype, self.device, fft, len(self.depths), self.volume)
        self.fft = make_fft(fft, n, n, self.device, self.dtype)
        spec = self.fft.spectral_shape
        cplx = self.fft.complex_dtype
        with wp.ScopedDevice(self.device):
            self._field = wp.zeros((n, n), dtype=self.dtype)
            self._corners = wp.zeros((n + 1, n + 1), dtype=wp.float64)
            # written before they are read, so not zeroed (a CPU page is then touched only where
            # written: a pressure alone uses 8 of the 14 basis spectra, the lean pass one of the
            # six derived fields): the basis spectra a depth's terms use (``_basis_spectra``), the
            # stress spectra and stresses every component, the derived fields those a pass reads
            # (each stack one 2-D array of spectra one above the other, ``_spectrum``: Warp's
            # strides are 32-bit, and a (k, rows, cols) array's first stride, one spectrum, passes
            # 2^31 bytes at n = 8192 in complex128, where the kernels then read outside the array)
            self._basis = wp.empty((len(BASIS) * spec[0], spec[1]), dtype=cplx)
            # zeroed: ``stress_spectra`` takes its zero from the first traction's spectrum, loaded or not
            self._traction = wp.zeros((3 * spec[0], spec[1]), dtype=cplx)
            self._stress_spectra = wp.empty((6 * spec[0], spec[1]), dtype=cplx)
            self._stress = wp.empty((6, n, n), dtype=self.dtype)
            self._derived = wp.empty((6, n, n), dtype=self.dtype)
            # each basis's spectrum in the stack (its own index), -1 for a basis the loads do not use
            self._slots = wp.zeros(len(BASIS), dtype=int)
            self._row_values = wp.zeros(n, dtype=self.dtype)
            self._row_columns = wp.zeros(n, dtype=int)
            self._line = wp.zeros((6, n), dtype=self.dtype)
        #: which of the tractions (p, q_x, q_y) the last ``_load_tractions`` loaded as non-zero
        self._loads = (True, True, True)
        from .launch import LaunchCache

        #: the stress kernels' launches, split by rows over the CPU's threads (``_rows``)
        self.launches = LaunchCache(self.device)

    def _launch(self, kernel, dim, inputs, outputs=()):
        import warp as wp

        wp.launch(kernel, dim=dim, inputs=inputs, outputs=list(outputs), device=self.device)

    def _rows(self, kernel, shape, inputs, outputs, work: int = 1):
        """``kernel`` over a (rows, columns) ``shape``, its last input the first row of the launch
        (``row0``): on the CPU, where Warp runs a launch on one thread and lets go of the GIL, the
        rows split in blocks over the CPU's threads as the solvers' launches are
        (``LaunchCache.split``, its threshold and threads); one plain launch on CUDA (the
        arguments change with the depth and the basis, so a recorded launch would not repeat).
        ``work``: the kernel's work an entry in elementwise passes' (``STRESS_SPECTRA_WORK``), which
        lowers the entries from which it is split in proportion."""
        from .launch import FirstRow

        if self.device.is_cuda:
            self._launch(kernel, shape, [*inputs, 0], outputs)
            return
        columns = shape[1]
        args = [*inputs, FirstRow()]
        self.launches.split(kernel, shape, lambda r0, r1: ((r1 - r0, columns), args), args, outputs,
                            min_entries=-(-self.launches.min_split_entries // max(1, int(work))))

    def _basis_spectra(self, z_cells: float):
        """The spectra of the weighted basis quadrants at depth ``z_cells`` that the loaded
        tractions use (``used_bases``: a pressure alone uses 8 of the 14)."""
        import warp as wp

        from warpcontact.kernels import stress as ks

        n = self.grid.n
        for b in used_bases(self._loads):
            self._rows(ks.basis_corners, (n + 1, n + 1), [b, wp.float64(z_cells)], [self._corners])
            self._rows(ks.basis_quadrant, (n, n), [self._corners, 1], [self._field])
            self.fft.forward(self._field, self._spectrum(self._basis, b))

    def _spectrum(self, stack, k: int):
        """Spectrum ``k`` of a stack of spectra (rows k rows .. (k + 1) rows - 1 of its 2-D array):
        a view, (rows, cols) as the FFT backend lays out one spectrum."""
        rows = self.fft.spectral_shape[0]
        return stack[k * rows:(k + 1) * rows]

    def _load_tractions(self, pressure, shear_x, shear_y) -> None:
        """The spectra of the tractions: (n, n) numpy arrays [Pa], scaled by E* here, or (n, n)
        Warp arrays on this device in this float type, already scaled by E* (a ContactState's
        units): transformed where they are, nothing copied. A traction that is None or a numpy
        array of zeros is not transformed, and its terms are left out of the stress
        (``_loads``)."""
        import warp as wp

        n = self.grid.n
        loads = []
        for k, t in enumerate((pressure, shear_x, shear_y)):
            loads.append(t is not None and (isinstance(t, wp.array) or bool(np.any(t))))
            if not loads[-1]:  # zero: no transform, and the terms of this load are left out
                continue
            if isinstance(t, wp.array):
                if t.shape != (n, n) or t.device != self.device or t.dtype != self.dtype:
                    raise InputError("tractions", f"expected Warp arrays of shape {(n, n)} on {self.device} in "
                                                  f"{self.dtype_name}, got {t.shape} on {t.device}")
                self.fft.forward(t, self._spectrum(self._traction, k))
                continue
            t = np.asarray(t, dtype=np.float64)
            if t.shape != (n, n):
                raise InputError("tractions", f"expected arrays of shape {(n, n)}, got {t.shape}")
            self._field.assign(np.ascontiguousarray(t / self.pair.E_star, dtype=self.np_dtype))
            self.fft.forward(self._field, self._spectrum(self._traction, k))
        self._loads = tuple(loads)
        used = used_bases(self._loads)
        self._slots.assign(np.array([b if b in used else -1 for b in range(len(BASIS))], dtype=np.int32))

    def _body_stress(self, name: str, z_cells: float) -> None:
        """The six stress components of body ``name`` into ``self._stress`` (scaled by E*) from the
        loaded traction spectra and the basis spectra of its depth ``z_cells`` (:meth:`_basis_spectra`):
        its stress table's terms (``kernels/stress.py``, ``stress_spectra``; ``body_coefficients``)."""
        from warpcontact.kernels import stress as ks

        coefficients = body_coefficients(self.pair.elastic[name].nu, name == "sphere", z_cells, self._loads)
        self._rows(ks.stress_spectra, self.fft.spectral_shape,
                   [self._basis, self._traction, self._slots, *(self.dtype(c) for c in coefficients),
                    self.fft.half_axis, self.fft.spectral_shape[0]],
                   [self._stress_spectra], work=STRESS_SPECTRA_WORK)
        for k in range(6):
            self.fft.inverse(self._spectrum(self._stress_spectra, k), self._stress[k])

    def von_mises_maxima(self, pressure, shear_x, shear_y, depths) -> dict:
        """The largest von Mises stress of each body at each of ``depths`` [m] under the total
        tractions [Pa]: {body: (len(depths), 3) array of value [Pa], x, y [m]}. The yield check's
        lean pass: no principal stresses, sections or volume (:meth:`evaluate` has them)."""
        from warpcontact.kernels import stress as ks

        n, dx = self.grid.n, self.grid.dx
        self._load_tractions(pressure, shear_x, shear_y)
        depths = check_depths(depths)
        out = {name: np.zeros((len(depths), 3)) for name in self.bodies}
        for k, z in enumerate(depths):
            self._basis_spectra(z / dx)
            for name in self.bodies:
                self._body_stress(name, z / dx)
                self._launch(ks.von_mises_field, (n, n), [self._stress], [self._derived])
                v, r, col = self._row_max(0)
                out[name][k] = (v * self.pair.E_star, self.grid.x[col], self.grid.y[r])
        return out

    def _row_max(self, which: int) -> tuple[float, int, int]:
        """(largest value of derived field ``which``, its row, its column) (scaled units)."""
        from warpcontact.kernels import stress as ks

        self._launch(ks.row_maxima, self.grid.n, [self._derived, which], [self._row_values, self._row_columns])
        values = self._row_values.numpy()
        r = int(np.argmax(values))
        return float(values[r]), r, int(self._row_columns.numpy()[r])

    def evaluate(self, pressure, shear_x, shear_y, section_axis: str = "x") -> StressResult:
        """The stress of the total tractions ``pressure``, ``shear_x``, ``shear_y`` [Pa] ((n, n)
        arrays on the grid, numpy, or None for zero; shear: the traction the sphere exerts on the
        flat), in both
        bodies at every depth. ``section_axis``: the direction of the section through the centre
        ("x" or "y")."""
        import warp as wp

        from warpcontact.kernels import stress as ks

        if section_axis not in ("x", "y"):
            raise InputError("section_axis", f"must be 'x' or 'y', got {section_axis!r}")
        t0 = time.perf_counter()
        n, dx = self.grid.n, self.grid.dx
        scale = self.pair.E_star
        self._load_tractions(pressure, shear_x, shear_y)
        centre = n // 2  # the cell centre nearest 0 (x = +dx/2 for even n)
        along_x = section_axis == "x"
        nz = len(self.depths)
        bodies = {}
        for name in self.bodies:
            m = self.pair.elastic[name]
            bodies[name] = BodyStress(name, m.nu, m.yield_strength,
                                      section={f: np.zeros((nz, n)) for f in FIELDS},
                                      depth_max={"von_mises": np.zeros((nz, 3)), "tresca": np.zeros((nz, 3))},
                                      volume={f: np.zeros((nz, n, n)) for f in FIELDS} if self.volume else None)
        xs, ys = self.grid.x, self.grid.y
        for k, z in enumerate(self.depths):
            z_cells = z / dx
            self._basis_spectra(z_cells)
            for name in self.bodies:
                body = bodies[name]
                self._body_stress(name, z_cells)
                self._launch(ks.derived_fields, (n, n), [self._stress], [self._derived])
                for which, key in ((0, "von_mises"), (1, "tresca")):
                    v, r, col = self._row_max(which)
                    body.depth_max[key][k] = (v * scale, xs[col], ys[r])
                for src, offset in ((self._stress, 0), (self._derived, 6)):
                    self._launch(ks.take_line, (6, n), [src, centre, int(along_x)], [self._line])
                    line = self._line.numpy().astype(np.float64) * scale
                    for f in range(6):
                        body.section[FIELDS[offset + f]][k] = line[f]
                if self.volume:
                    for src, offset in ((self._stress, 0), (self._derived, 6)):
                        arr = src.numpy().astype(np.float64) * scale
                        for f in range(6):
                            body.volume[FIELDS[offset + f]][k] = arr[f]
        wp.synchronize_device(self.device)
        for body in bodies.values():
            body.axis = {f: body.section[f][:, centre].copy() for f in FIELDS}
        return StressResult(
            depths=self.depths.copy(), x=xs, y=ys, section_axis=section_axis, section_index=centre,
            axis_index=(centre, centre), bodies=bodies, elapsed_s=time.perf_counter() - t0,
            device=str(self.device), dtype=self.dtype_name, fft=self.fft.name,
            rigid=tuple(b for b in BODIES if b not in self.bodies))


def tractions(fields: dict) -> tuple:
    """(p, q_x, q_y) [Pa], the total tractions (elastic and adhesive) of one state's fields (SI,
    as ``results.state_fields`` or one entry of ``fields.npz``)."""
    def total(a, b):
        f = np.asarray(fields[a], dtype=np.float64)
        return f + np.asarray(fields[b], dtype=np.float64) if b in fields else f

    return (total("pressure", "adhesive_pressure"), total("shear_x", "adhesive_shear_x"),
            total("shear_y", "adhesive_shear_y"))


def sliding_axis(delta) -> str:
    """"x" or "y": the direction of the larger tangential approach (x when neither)."""
    dx, dy = (float(delta[0]), float(delta[1])) if not isinstance(delta, dict) else (delta["x"], delta["y"])
    return "y" if abs(dy) > abs(dx) else "x"


def contact_radius(fields: dict, cell_area: float) -> float:
    """sqrt(A_c / pi) [m] of one state's fields (A_c: cells with elastic pressure > 0)."""
    return math.sqrt(float(np.count_nonzero(np.asarray(fields["pressure"]) > 0)) * cell_area / math.pi)
