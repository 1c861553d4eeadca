"""Subsurface stress (warpcontact/numerics/stress.py, yielding.py, kernels/stress.py) against closed forms
(warpcontact/numerics/stress_reference.py).

Grids are small (n <= 65) so that the file runs in well under a minute on 2 CPU cores; each
tolerance says where it comes from.
"""

import json
import math
import os

import numpy as np
import pytest
import warp as wp
from scipy.integrate import dblquad

from warpcontact.numerics import stress as st
from warpcontact.numerics import stress_reference as sr
from warpcontact.numerics import yielding
from warpcontact.studies import stress_study
from warpcontact.records.case import case_from_dict
from warpcontact.errors import InputError
from warpcontact.physics.geometry import Grid
from warpcontact.physics.materials import Material, MaterialPair

from conftest import DEVICES

#: two different materials: the sphere's nu = 0.33 (copper), the flat's 0.22
PAIR = MaterialPair(Material(E=106e9, nu=0.33, yield_strength=200e6, name="sphere"),
                    Material(E=70e9, nu=0.22, yield_strength=345e6, name="flat"))
BACKENDS = ("scipy", "warp")  # the CPU backends (fftw is scipy's layout)


def _cerruti_y(x, y, z, nu):
    """The stress of a unit force along +y: Cerruti's along +x with x and y exchanged."""
    s = sr.cerruti_point_stress(y, x, z, nu)
    return {"sigma_xx": s["sigma_yy"], "sigma_yy": s["sigma_xx"], "sigma_zz": s["sigma_zz"],
            "sigma_xy": s["sigma_xy"], "sigma_xz": s["sigma_yz"], "sigma_yz": s["sigma_xz"]}


REFERENCES = (sr.boussinesq_point_stress, sr.cerruti_point_stress, _cerruti_y)


# --- the cell integrals -----------------------------------------------------------------------


@pytest.mark.parametrize("z_cells", [0.3, 1.7])
def test_cell_integrals_equal_quadrature_of_the_point_force_solutions(z_cells):
    """Each of the 18 cell kernels (6 components x 3 tractions) equals the numerical quadrature of
    the textbook point-force stresses (Johnson eq. 3.18; Cerruti) over the cell, at the cell under
    the point itself and its neighbours (where the closed forms straddle the axes) and further
    out. Tolerance 1e-9 of the largest kernel: the quadrature's (epsabs 1e-12)."""
    nu = 0.3
    K = st.cell_kernels(nu, z_cells, 5)
    scale = np.abs(K).max()
    for i, j in ((0, 0), (0, 1), (1, 0), (1, 1), (2, 3), (4, 1)):
        for load, ref in enumerate(REFERENCES):
            for c, name in enumerate(st.COMPONENTS):
                exact, _ = dblquad(lambda ys, xs: float(ref(j - xs, i - ys, z_cells, nu)[name]),
                                   -0.5, 0.5, -0.5, 0.5, epsabs=1e-12, epsrel=1e-10)
                assert abs(K[c, load, i, j] - exact) <= 1e-9 * scale, (z_cells, i, j, load, name)


def test_cell_integrals_tend_to_the_point_force_far_away():
    """Far from the cell its kernel is the point-force stress times the cell's area, to the
    midpoint rule's error: cell average - centre value = (1/24) (f_xx + f_yy) + O(h^4 / r^6) for
    a unit cell. At r >= 24 cells the residual after that term is under 1e-3 of the largest |f|
    (the O(h^4) term: about 1/(1920 r^4) relative), and the plain difference is under 1 / r^2 of
    it (second order; measured up to 0.5 / r^2 for sigma_xx, whose surface part decays as 1/r^2)."""
    nu, z = 0.27, 6.0
    size = 40
    K = st.cell_kernels(nu, z, size)
    h = 1e-3
    for load, ref in enumerate(REFERENCES):
        for c, name in enumerate(st.COMPONENTS):
            for i, j in ((0, 30), (24, 0), (20, 25), (33, 11)):
                f = ref(j, i, z, nu)[name]
                lap = ((ref(j + h, i, z, nu)[name] + ref(j - h, i, z, nu)[name]
                        + ref(j, i + h, z, nu)[name] + ref(j, i - h, z, nu)[name] - 4 * f) / h**2)
                r2 = i * i + j * j + z * z
                big = max(abs(ref(j, i, z, nu)[k]) for k in st.COMPONENTS) + 1e-300
                assert abs(K[c, load, i, j] - f) <= big / r2, (name, load, i, j)
                assert abs(K[c, load, i, j] - f - lap / 24.0) <= 1e-3 * big, (name, load, i, j)


def test_surface_limits_of_the_cell_kernels():
    """Just below a loaded cell (z = 1e-4 cell) the stress is the traction: sigma_zz = -p,
    sigma_xz = -q_x, sigma_yz = -q_y under the cell and 0 beside it (tension positive, z into the
    body). Tolerance 1e-3: the stress at depth z differs from its surface value by O(z) cells."""
    K = st.cell_kernels(0.3, 1e-4, 3)
    ZZ, XZ, YZ = 2, 4, 5
    assert K[ZZ, 0, 0, 0] == pytest.approx(-1.0, abs=1e-3)
    assert K[XZ, 1, 0, 0] == pytest.approx(-1.0, abs=1e-3)
    assert K[YZ, 2, 0, 0] == pytest.approx(-1.0, abs=1e-3)
    for c, load in ((ZZ, 0), (XZ, 1), (YZ, 2), (XZ, 0), (ZZ, 1)):
        assert abs(K[c, load, 1, 2]) < 1e-3 and abs(K[c, load, 2, 0]) < 1e-3


# --- the convolution --------------------------------------------------------------------------


def _kernel_parity(c, load):
    """(odd in x, odd in y) of the kernel of component c under traction ``load``: that of its
    basis functions (all of one entry share it)."""
    table = st.stress_table(0.3, 1.0)
    kinds = {st.BASIS_PARITY[b] for b in np.nonzero(table[c, load])[0]}
    assert len(kinds) == 1, (c, load, kinds)
    kind = kinds.pop()
    return bool(kind & 1), bool(kind & 2)


def _direct_sum(p, qx, qy, nu, z_cells):
    """sigma[c] at every cell by summing every loaded cell's kernel (negative offsets by parity)."""
    n = p.shape[0]
    K = st.cell_kernels(nu, z_cells, n)
    out = np.zeros((6, n, n))
    oi, oj = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    for load, t in enumerate((p, qx, qy)):
        for c in range(6):
            odd_x, odd_y = _kernel_parity(c, load)
            for bi, bj in zip(*np.nonzero(t)):
                di, dj = oi - bi, oj - bj
                v = K[c, load, np.abs(di), np.abs(dj)]
                if odd_x:
                    v = np.where(dj < 0, -v, v)
                if odd_y:
                    v = np.where(di < 0, -v, v)
                out[c] += v * t[bi, bj]
    return out


@pytest.mark.parametrize("fft", BACKENDS)
@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_fft_convolution_equals_the_direct_sum(fft, dtype):
    """The DC-FFT with the quadrant's parity reconstruction equals the direct sum over cells of
    random tractions (n = 7, odd, and the warp backend's padding to a power of two): no periodic
    images, every parity right. Tolerance: rounding, 1e-10 (float64) or 2e-5 (float32) of the
    largest stress."""
    rng = np.random.default_rng(3)
    n, dx = 7, 1e-9
    grid = Grid(8, 8 * dx)  # Grid needs n >= 8: use 8 here and 7 through a sub-block of zeros
    p, qx, qy = (rng.uniform(-1, 1, (8, 8)) * 1e8 for _ in range(3))
    for t in (p, qx, qy):
        t[n:, :] = 0.0
        t[:, n:] = 0.0
    depths = np.array([0.4, 2.5]) * dx
    res = st.SubsurfaceStress(PAIR, grid, depths, dtype=dtype, fft=fft, volume=True).evaluate(p, qx, qy)
    for name, sign, mat in (("flat", 1.0, PAIR.flat), ("sphere", -1.0, PAIR.sphere)):
        for k, z in enumerate(depths):
            ref = _direct_sum(p / 1.0, sign * qx, sign * qy, mat.nu, z / dx)
            got = np.stack([res.bodies[name].volume[c][k] for c in st.COMPONENTS])
            tol = (1e-10 if dtype == "float64" else 2e-5) * np.abs(ref).max()
            assert np.abs(got - ref).max() <= tol, (name, k, np.abs(got - ref).max() / np.abs(ref).max())


def test_derived_fields_match_numpy():
    """Principal stresses against numpy.linalg.eigvalsh, von Mises sqrt(3 J2), maximum shear
    (s1 - s3)/2, hydrostatic: random tensors, float64 to 1e-12 and float32 to 1e-5 relative."""
    from warpcontact.kernels import stress as ks

    rng = np.random.default_rng(7)
    s = rng.normal(size=(6, 5, 5))
    s[:, 0, 0] = (1.0, 1.0, 1.0, 0.0, 0.0, 0.0)  # a hydrostatic state: J2 = 0
    s[:, 0, 1] = (2.0, 1.0, 1.0, 0.0, 0.0, 0.0)  # two equal eigenvalues
    for dtype, tol in ((wp.float64, 1e-12), (wp.float32, 1e-5)):
        npdt = np.float64 if dtype == wp.float64 else np.float32
        a = wp.array(s.astype(npdt), dtype=dtype, device="cpu")
        d = wp.zeros((6, 5, 5), dtype=dtype, device="cpu")
        wp.launch(ks.derived_fields, dim=(5, 5), inputs=[a], outputs=[d], device="cpu")
        d = d.numpy()
        for i in range(5):
            for j in range(5):
                xx, yy, zz, xy, xz, yz = s[:, i, j]
                T = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
                ev = np.linalg.eigvalsh(T)[::-1]
                dev = T - np.trace(T) / 3 * np.eye(3)
                vm = math.sqrt(1.5 * np.sum(dev * dev))
                scale = max(1.0, np.abs(ev).max())
                np.testing.assert_allclose(d[2:5, i, j], ev, atol=tol * scale * 10)
                assert d[0, i, j] == pytest.approx(vm, abs=tol * scale * 10)
                assert d[1, i, j] == pytest.approx(0.5 * (ev[0] - ev[2]), abs=tol * scale * 10)
                assert d[5, i, j] == pytest.approx(np.trace(T) / 3, abs=tol * scale)


# --- Hertz, equilibrium, symmetry ---------------------------------------------------------------


def _hertz_pressure(grid, a, p0):
    X, Y = grid.mesh()
    return p0 * np.sqrt(np.clip(1.0 - (X**2 + Y**2) / a**2, 0.0, None))


@pytest.mark.parametrize("fft", BACKENDS)
@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_hertz_axis_stresses_in_both_bodies(fft, dtype):
    """A Hertz pressure (sampled at the cell centres) on both bodies, nu = 0.33 and 0.22: sigma_zz
    and sigma_xx = sigma_yy = sigma_rr on the axis within 1 % of p0 of Johnson's eq. 3.45 from
    0.05 a to 1.5 a, at n = 65 with a = 21.7 cells (the sampled pressure's error near the edge,
    where it behaves as sqrt(a - r), is O((dx/a)^1.5) = 1 % of p0: the bound; measured 2e-4). Each
    body's von Mises maximum within 0.5 % of its closed form and its depth within 2 % of a."""
    a, p0, n = 1e-6, 1e9, 65
    grid = Grid(n, 3 * a)
    p = _hertz_pressure(grid, a, p0)
    z = np.linspace(0.05, 1.5, 30) * a
    res = st.SubsurfaceStress(PAIR, grid, z, dtype=dtype, fft=fft).evaluate(p, 0 * p, 0 * p)
    for name in st.BODIES:
        b = res.bodies[name]
        ref = sr.hertz_axis_stress(z / a, b.nu)
        for f, r in (("sigma_zz", "sigma_zz"), ("sigma_xx", "sigma_rr"), ("sigma_yy", "sigma_rr")):
            err = np.abs(b.axis[f] / p0 - ref[r]).max()
            assert err < 0.01, f"{name} {f}: {err:.2e} p0 off Hertz on the axis"
        vm = b.maximum("von_mises", res.depths)
        value, depth = sr.hertz_von_mises_max(b.nu)
        assert vm["value"] / p0 == pytest.approx(value, rel=0.005), name
        assert abs(vm["z"] / a - depth) < 0.02, name


def test_hertz_von_mises_maximum_closed_form():
    """The closed form's maximum for nu = 0.3: 0.62 p0 at 0.48 a (Johnson, Fig. 3.9)."""
    value, depth = sr.hertz_von_mises_max(0.3)
    assert value == pytest.approx(0.62, abs=0.005) and depth == pytest.approx(0.48, abs=0.005)


def _square_fractions(z, half):
    """The fractions of a unit normal and a unit tangential point force at the centre carried
    through the square |x|, |y| <= ``half`` at depth z: the integrals there of Boussinesq's
    -sigma_zz = 3 z^3 / (2 pi rho^5) and Cerruti's -sigma_xz = 3 x^2 z / (2 pi rho^5), the y
    integral in closed form (int dy / (s^2 + y^2)^(5/2) = y (2 y^2 + 3 s^2) / (3 s^4 (s^2 +
    y^2)^(3/2)), s^2 = x^2 + z^2) and the x integral by quadrature."""
    from scipy.integrate import quad

    def inner(x):
        s2 = x * x + z * z
        return 2 * half * (2 * half**2 + 3 * s2) / (3 * s2**2 * (s2 + half**2) ** 1.5)

    normal, _ = quad(lambda x: 3 * z**3 / (2 * np.pi) * inner(x), -half, half, epsabs=1e-12, points=[0.0])
    tangential, _ = quad(lambda x: 3 * x * x * z / (2 * np.pi) * inner(x), -half, half, epsabs=1e-12, points=[0.0])
    return normal, tangential


@pytest.mark.parametrize("depth_cells", [0.5, 3.0, 9.0])
def test_equilibrium_force_through_a_plane(depth_cells):
    """sigma_zz summed over the plane at depth z carries the applied normal force, and sigma_xz
    the tangential one, to the truncation of the domain: a 3 x 3 cell load at the centre of n =
    33 cells carries through the grid's plane the fraction that a point force carries through the
    square (its own closed form, integrated numerically: 0.99998, 0.996, 0.913 of the normal force
    and 0.96, 0.76, 0.38 of the tangential one at these depths). Tolerance 2e-3 of the force: the
    load's 3 cells against a point, seen from the domain's edge 15 cells away (measured 9e-4)."""
    n, dx = 33, 1e-9
    grid = Grid(n, n * dx)
    p, qx = np.zeros((n, n)), np.zeros((n, n))
    c = n // 2
    p[c - 1:c + 2, c - 1:c + 2] = 1e8
    qx[c - 1:c + 2, c - 1:c + 2] = 3e7
    z = depth_cells * dx
    res = st.SubsurfaceStress(PAIR, grid, [z], volume=True).evaluate(p, qx, 0 * p)
    fz, fx = p.sum() * dx * dx, qx.sum() * dx * dx
    half = 0.5 * n * dx
    for name, sign in (("flat", 1.0), ("sphere", -1.0)):
        v = res.bodies[name].volume
        through_z = -v["sigma_zz"][0].sum() * dx * dx
        through_x = -v["sigma_xz"][0].sum() * dx * dx
        share_z, share_x = _square_fractions(z, half)
        assert through_z == pytest.approx(fz * share_z, abs=2e-3 * fz), name
        assert through_x == pytest.approx(sign * fx * share_x, abs=2e-3 * fx), name


def test_symmetry_of_the_frictionless_field():
    """A frictionless Hertz pressure on an even grid, symmetric under x -> -x, y -> -y and x <-> y:
    sigma_xx, sigma_yy, sigma_zz even in x and y, sigma_xz odd in x, sigma_yz odd in y, sigma_xy
    odd in both, sigma_yy the transpose of sigma_xx; von Mises even. Tolerance: rounding, 1e-12
    of the largest stress (float64)."""
    a = 1e-6
    grid = Grid(32, 3 * a)
    p = _hertz_pressure(grid, a, 1e9)
    res = st.SubsurfaceStress(PAIR, grid, [0.3 * a, 0.8 * a], volume=True).evaluate(p, 0 * p, 0 * p)
    for name in st.BODIES:
        v = res.bodies[name].volume
        tol = 1e-12 * max(np.abs(v[f]).max() for f in st.COMPONENTS)
        flip_x, flip_y = (lambda f: f[:, :, ::-1]), (lambda f: f[:, ::-1, :])
        for f in ("sigma_xx", "sigma_yy", "sigma_zz", "von_mises", "hydrostatic"):
            assert np.abs(v[f] - flip_x(v[f])).max() <= tol and np.abs(v[f] - flip_y(v[f])).max() <= tol, f
        assert np.abs(v["sigma_xz"] + flip_x(v["sigma_xz"])).max() <= tol
        assert np.abs(v["sigma_yz"] + flip_y(v["sigma_yz"])).max() <= tol
        assert np.abs(v["sigma_xy"] + flip_x(v["sigma_xy"])).max() <= tol
        assert np.abs(v["sigma_xy"] + flip_y(v["sigma_xy"])).max() <= tol
        assert np.abs(v["sigma_yy"] - v["sigma_xx"].transpose(0, 2, 1)).max() <= tol


def test_zero_shear_left_out_and_rows_split_change_no_bit():
    """The evaluation leaves out the terms of a zero traction (a shear given as None, or as numpy
    zeros: neither transformed nor summed, and the basis kernels only the pressure uses are the
    ones made) and splits its kernels' rows over the CPU's threads (n = 256: 65536 entries). Each
    entry is computed alone and the terms left out only add zeros, so every stress is the same to
    the last bit as with the shear's spectra (Warp arrays of zeros, summed) and on one thread."""
    import warp as wp

    a = 1e-6
    grid = Grid(256, 3 * a)
    p = _hertz_pressure(grid, a, 1e9)
    depths = [0.02 * a, 0.5 * a]
    results = []
    for shear, threads in (("none", None), ("numpy", None), ("warp", None), ("none", 1)):
        evaluator = st.SubsurfaceStress(PAIR, grid, depths, volume=True)
        if threads:
            evaluator.launches.workers = threads
        if shear == "warp":  # (device arrays are loaded as they are: their terms are summed)
            zero = wp.zeros(grid.shape, dtype=wp.float64, device="cpu")
            pressure = wp.array(p / PAIR.E_star, dtype=wp.float64, device="cpu")
            results.append(evaluator.evaluate(pressure, zero, zero))
            assert evaluator._loads == (True, True, True)
            continue
        q = None if shear == "none" else 0 * p
        results.append(evaluator.evaluate(p, q, q))
        assert evaluator._loads == (True, False, False) and evaluator.launches.workers == (threads or os.cpu_count())
    for other in results[1:]:
        for name in st.BODIES:
            for f in st.FIELDS:
                assert np.array_equal(other.bodies[name].volume[f], results[0].bodies[name].volume[f]), (name, f)


def test_sphere_carries_minus_the_shear():
    """With identical materials the flat under (p, q_x) and the sphere under (p, -q_x) are mirror
    images in x (p even): the sphere's invariants and sigma_zz at x are the flat's at -x, its
    sigma_xz the negative of the flat's at -x (a reflection of x turns its sign). Rounding
    tolerance."""
    mat = Material(E=100e9, nu=0.3)
    pair = MaterialPair(mat, mat)
    a = 1e-6
    grid = Grid(24, 3 * a)
    p = _hertz_pressure(grid, a, 1e9)
    res = st.SubsurfaceStress(pair, grid, [0.2 * a, 0.5 * a], volume=True).evaluate(p, 0.4 * p, 0 * p)
    s, f = res.bodies["sphere"].volume, res.bodies["flat"].volume
    tol = 1e-12 * np.abs(f["von_mises"]).max()
    assert np.abs(s["von_mises"] - f["von_mises"][:, :, ::-1]).max() <= tol
    assert np.abs(s["sigma_zz"] - f["sigma_zz"][:, :, ::-1]).max() <= tol
    assert np.abs(s["sigma_xz"] + f["sigma_xz"][:, :, ::-1]).max() <= tol
    assert np.abs(s["von_mises"] - f["von_mises"]).max() > 1e3 * tol  # the shear makes them differ


def _hertz_traction_quadrature(x, y, z, a, p0, mu, nu, nt=64, nth=256):
    """The stress at (x, y, z) of the continuous Hertz pressure p0 sqrt(1 - r^2/a^2) with the
    shear mu p along +x (full sliding): the point-force solutions (Boussinesq, Cerruti)
    integrated over the disc, r = a sin t (the edge's square root made smooth), Gauss-Legendre
    in t and the trapezoidal rule in the angle (exact for a periodic integrand): about 1e-7 p0."""
    t, wt = np.polynomial.legendre.leggauss(nt)
    t, wt = (t + 1) * np.pi / 4, wt * np.pi / 4
    th = np.arange(nth) * 2 * np.pi / nth
    T, TH = np.meshgrid(t, th, indexing="ij")
    r = a * np.sin(T)
    xi, eta = r * np.cos(TH), r * np.sin(TH)
    w = wt[:, None] * (2 * np.pi / nth) * r * a * np.cos(T) * p0 * np.cos(T)
    b = sr.boussinesq_point_stress(x - xi, y - eta, z, nu)
    c = sr.cerruti_point_stress(x - xi, y - eta, z, nu)
    return {k: float(np.sum(w * (b[k] + mu * c[k]))) for k in st.COMPONENTS}


@pytest.mark.parametrize("mu", [0.25, 0.5])
def test_sliding_hertz_against_quadrature(mu):
    """Hertz pressure with the sliding shear mu p (Hamilton 1983's problem; his closed form is
    not implemented here: the reference is the quadrature of the point-force solutions over the
    continuous tractions, ``_hertz_traction_quadrature``). At n = 49 (a = 16.3 cells) every stress
    component at points of the x-z section within 1 % of p0 (the sampled tractions' error, as in
    the frictionless test; measured 3e-4 at n = 65). The largest von Mises stress lies below the
    surface at mu = 0.25 (0.647 p0 at 0.44 a, n = 65) and at the surface at mu = 0.5 (0.88 p0 at
    x = -0.42 a): Hamilton's finding that it reaches the surface above mu ~ 0.3."""
    mat = Material(E=100e9, nu=0.3)
    a, p0, n = 1e-6, 1e9, 49
    grid = Grid(n, 3 * a)
    p = _hertz_pressure(grid, a, p0)
    z = np.linspace(0.03, 1.0, 30) * a
    res = st.SubsurfaceStress(MaterialPair(mat, mat), grid, z).evaluate(p, mu * p, 0 * p)
    b = res.bodies["flat"]
    for xa, za in ((-0.5, 0.2), (0.0, 0.5), (0.3, 0.3), (0.6, 0.1), (-0.2, 0.8)):
        j, k = int(np.argmin(abs(grid.x - xa * a))), int(np.argmin(abs(z - za * a)))
        ref = _hertz_traction_quadrature(grid.x[j], grid.y[n // 2], z[k], a, p0, mu, 0.3)
        for comp in st.COMPONENTS:
            assert abs(b.section[comp][k, j] - ref[comp]) < 0.01 * p0, (mu, xa, za, comp)
    vm = b.maximum("von_mises", res.depths)
    if mu == 0.25:
        assert 0.3 * a < vm["z"] < 0.6 * a and vm["value"] == pytest.approx(0.647 * p0, rel=0.02)
    else:
        assert vm["z_on_grid"] == z[0] and vm["value"] == pytest.approx(0.88 * p0, rel=0.03)


# --- from a case: the solved Hertz contact of two materials, first yield, memory, CLI ----------


def _hertz_case(n=65, steps=3, sphere_yield=200e6, **solver):
    R, dz = 10e-6, 1e-10
    a = math.sqrt(R * dz)
    d = {"sphere": {"radius": R, "E": 106e9, "nu": 0.33, "yield_strength": sphere_yield},
         "flat": {"E": 70e9, "nu": 0.22, "yield_strength": 345e6},
         "grid": {"n": n, "size": 3 * a}, "load": {"delta_z": dz, "steps": steps}}
    if solver:
        d["solver"] = solver
    return case_from_dict(d), a


def test_solved_hertz_contact_puts_each_maximum_where_hertz_does():
    """The stress of a solved contact against Hertz's: frictionless Hertz between two materials (nu 0.33 and 0.22),
    solved by the contact solver at n = 65 (a = 21.7 cells) and the stress evaluated at 32 depths
    down to 2 a: each body's von Mises maximum within 2 % of Hertz's closed form (0.606 and 0.658
    p0) and its depth within 5 % of a (0.491 a and 0.454 a). The solver's pressure differs from
    Hertz by the discretisation of the contact edge, about (dx/a)^1.5 = 1 % of p0 at most."""
    case, a = _hertz_case(steps=1)
    res = stress_study.subsurface_stress(case, with_first_yield=False)
    p0 = 2 * case.pair.E_star * a / (math.pi * case.sphere.radius)
    summary = res.summary()
    for name in st.BODIES:
        vm = summary[name]["von_mises_max"]
        value, depth = sr.hertz_von_mises_max(res.bodies[name].nu)
        assert vm["value"] / p0 == pytest.approx(value, rel=0.02), name
        assert abs(vm["z"] / a - depth) < 0.05, name
        assert math.hypot(vm["x"], vm["y"]) < 0.05 * a, name
        assert summary[name]["yielded"] is False and summary[name]["margin"] > 1


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_the_yield_check_of_a_state_on_the_device_equals_the_one_from_its_fields(dtype, monkeypatch):
    """The check a solve makes from its state's tractions where they are (totalled, restricted to
    the half grid and transformed on the device; the pressure alone read on the host) is the one
    made from the state's SI fields on the host: the same depths, the maxima to the rounding of
    the float type (the host path scales by E* and back: float64 1e-12, float32 1e-5)."""
    import warpcontact as wc
    from warpcontact.studies.runner import build

    case, _ = _hertz_case(n=128, steps=1, dtype=dtype)  # a = 43 cells: the deep depths on the half grid
    grids = []
    original = st.SubsurfaceStress.von_mises_maxima
    monkeypatch.setattr(st.SubsurfaceStress, "von_mises_maxima",
                        lambda self, *a: grids.append(self.grid.n) or original(self, *a))
    _, solver, state = build(case)
    solver.step(state, case.load.path()[-1])
    host = yielding.yield_check(case.pair, case.grid, state.to_numpy_si(), state.model.device,
                                state.model.dtype_name, state.model.fft_name)
    on_host, grids[:] = list(grids), []
    device = yielding.state_yield_check(state, friction=False, adhesion=False)
    assert {128, 64} <= set(on_host) and {128, 64} <= set(grids)  # both checks on the fine and the half grid
    assert host["yielded"] is False and device["yielded"] is False
    rel = 1e-12 if state.model.dtype_name == "float64" else 1e-5
    for body in st.BODIES:
        assert device[body]["von_mises_max"] == pytest.approx(host[body]["von_mises_max"], rel=rel)
        assert device[body]["z"] == pytest.approx(host[body]["z"], rel=rel)
    assert wc.solve(case, fields="none").yield_check["sphere"]["margin"] == pytest.approx(
        host["sphere"]["margin"], rel=rel)


def test_first_yield_on_the_path():
    """With the sphere's yield strength at 50 MPa (its Hertz maximum is 55.4 MPa at the last of 4
    states) the sphere first yields at the last state and the flat not at all; the interpolated
    approach lies between the last two states' and within 1 % of Hertz's (S_Y / vm_max)^2
    delta_z (vm_max grows as sqrt(delta_z); linear interpolation over a quarter of the load errs
    by under 1 %)."""
    case, a = _hertz_case(n=33, steps=4, sphere_yield=50e6)
    res = stress_study.subsurface_stress(case, layers=16)
    fy = res.first_yield
    assert fy["flat"]["reached"] is False
    assert fy["sphere"]["reached"] is True and fy["sphere"]["state"] == 3
    dz = fy["sphere"]["delta_interpolated"]["z"]
    assert 0.75e-10 < dz <= 1e-10
    vm = res.summary()["sphere"]["von_mises_max"]["value"]
    assert dz == pytest.approx((50e6 / vm) ** 2 * 1e-10, rel=0.01)
    assert res.summary()["sphere"]["yielded"] is True


def test_first_yield_helper():
    deltas = [{"x": 0.0, "y": 0.0, "z": z} for z in (1.0, 2.0, 3.0)]
    assert yielding.first_yield([1.0, 2.0, 3.0], deltas, math.inf) is None
    r = yielding.first_yield([1.0, 2.0, 3.0], deltas, 2.5)
    assert r["state"] == 2 and r["delta_interpolated"]["z"] == pytest.approx(2.5)
    r = yielding.first_yield([4.0, 5.0], deltas[:2], 2.0)  # yielded at the first state: from zero load
    assert r["state"] == 0 and r["delta_interpolated"]["z"] == pytest.approx(0.5)
    assert yielding.first_yield([1.0], deltas[:1], 2.0)["reached"] is False


def test_memory_refusal_names_a_grid_that_fits():
    """A grid too large for the machine is refused before anything is allocated, naming the
    largest n that fits, which the estimate accepts."""
    with pytest.raises(InputError) as e:
        st.check_memory(400_000, "float64", "cpu", "scipy", 32)
    msg = str(e.value)
    assert "largest grid that fits is n = " in msg
    n_fit = int(msg.rsplit("n = ", 1)[1])
    assert 8 <= n_fit < 400_000
    st.check_memory(n_fit, "float64", "cpu", "scipy", 32)


def test_bad_depths_and_state_are_input_errors():
    with pytest.raises(InputError, match="depths"):
        st.check_depths([1e-9, -1e-9])
    with pytest.raises(InputError, match="depths"):
        st.check_depths([])
    case, _ = _hertz_case(n=16, steps=2)
    with pytest.raises(InputError, match="state"):
        stress_study.subsurface_stress(case, state=5)


def test_cli_stress_writes_json_npz_and_plots(tmp_path, capsys):
    from warpcontact.cli import main

    case, a = _hertz_case(n=24, steps=2, sphere_yield=50e6)
    path = tmp_path / "hz.toml"
    d = case.to_dict()
    lines = []
    for table, values in d.items():
        lines.append(f"[{table}]")
        for k, v in values.items():
            lines.append(f"{k} = {json.dumps(v)}")
    path.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    rc = main(["stress", str(path), "--out", str(out), "--layers", "8", "--quiet"])
    assert rc == 0
    s = json.loads((out / "stress.json").read_text())
    for name in ("sphere", "flat"):
        for key in ("von_mises_max", "tresca_max"):
            assert set(s[name][key]) >= {"value", "x", "y", "z"} and s[name][key]["z"] > 0
        assert "yielded" in s[name] and "margin" in s[name] and "first_yield" in s[name]
    # 8 layers and the surface
    assert s["sphere"]["yielded"] is True and s["complete"] is True and len(s["depths"]) == 9
    z = np.load(out / "stress.npz")
    assert z["sphere_section_von_mises"].shape == (9, 24) and z["flat_axis_sigma_zz"].shape == (9,)
    assert (out / "stress_section.png").stat().st_size > 0 and (out / "stress_profiles.png").stat().st_size > 0
    rc = main(["stress", str(path), "--out", str(out), "--depths", "0"])
    assert rc == 2 and "depths" in capsys.readouterr().err


@pytest.mark.parametrize("device", [d for d in DEVICES if d.startswith("cuda")] or
                         [pytest.param("cuda", marks=pytest.mark.skip(reason="no CUDA device here"))])
def test_cuda_matches_cpu(device):
    """The same evaluation on CUDA (its default FFT backend) as on the CPU: 1e-10 of the largest
    stress in float64."""
    a = 1e-6
    grid = Grid(32, 3 * a)
    p = _hertz_pressure(grid, a, 1e9)
    z = [0.3 * a, 0.6 * a]
    cpu = st.SubsurfaceStress(PAIR, grid, z).evaluate(p, 0.3 * p, 0 * p)
    gpu = st.SubsurfaceStress(PAIR, grid, z, device=device).evaluate(p, 0.3 * p, 0 * p)
    for name in st.BODIES:
        for f in st.FIELDS:
            ref = cpu.bodies[name].section[f]
            scale = np.abs(cpu.bodies[name].section["von_mises"]).max()
            assert np.abs(gpu.bodies[name].section[f] - ref).max() <= 1e-10 * scale, (name, f)


def test_yield_check_from_the_kept_fields_equals_the_one_from_the_state():
    """The yield check reads the last state's fields that the result keeps (one host copy of
    them) or, with fields="none", copies them itself: the same check either way, and
    ``wc.solve(fields=...)`` keeps what it is asked for (a wrong choice: an InputError naming it)."""
    import warpcontact as wc
    from warpcontact.errors import InputError

    case, _ = _hertz_case(n=33, steps=2)
    kept = wc.solve(case)
    bare = wc.solve(case, fields="none")
    last = wc.solve(case, fields="last")
    assert len(kept.fields) == 2 and bare.fields == [] and last.field_states == [1]
    assert kept.yield_check == bare.yield_check == last.yield_check
    assert kept.yield_check["sphere"]["von_mises_max"] > 0
    assert kept.states == bare.states
    with pytest.raises(InputError, match="fields"):
        wc.solve(case, fields="every")


@pytest.mark.parametrize("sphere_yield, yielded", [(50e6, True), (200e6, False)])
def test_every_solve_result_says_whether_a_body_yielded(sphere_yield, yielded):
    """run_path's summary (result.json of solve) carries ``yielded``, ``yield_margin`` (the
    smaller yield strength / von Mises maximum of the bodies) and the per-body check: the
    two-material Hertz contact's sphere reaches 55.4 MPa below the surface (0.606 p0)."""
    from warpcontact.studies.runner import run_path

    case, a = _hertz_case(n=33, steps=1, sphere_yield=sphere_yield)
    s = run_path(case, fields="none").summary(complete=True)
    assert s["yielded"] is yielded
    check = s["yield_check"]
    assert check["sphere"]["von_mises_max"] == pytest.approx(55.4e6, rel=0.02)
    assert check["flat"]["yielded"] is False
    assert s["yield_margin"] == pytest.approx(min(sphere_yield / check["sphere"]["von_mises_max"],
                                                  345e6 / check["flat"]["von_mises_max"]))
    json.dumps(s)  # JSON-ready
