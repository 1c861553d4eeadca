"""The coupled elastic operator: closed forms, reciprocity, decoupling, sign, DC-FFT."""

import numpy as np
import pytest
from scipy import integrate

from conftest import NEEDS_FFTW

from warpcontact.physics.geometry import Grid
from warpcontact.physics.influence import (
    KERNELS,
    cell_integral,
    influence_coefficients,
    influence_coefficients_device,
    point_kernels,
)
from warpcontact.physics.materials import COPPER, HARDENED_STEEL, PAPER_PAIR, MaterialPair
from warpcontact.numerics.operator import PRECONDITIONER_KERNELS, ElasticOperator

ELEMENTARY = {
    "inv_r": lambda x, y: 1.0 / np.hypot(x, y),
    "xx_r3": lambda x, y: x * x / np.hypot(x, y) ** 3,
    "yy_r3": lambda x, y: y * y / np.hypot(x, y) ** 3,
    "xy_r3": lambda x, y: x * y / np.hypot(x, y) ** 3,
    "x_r2": lambda x, y: x / (x * x + y * y),
    "y_r2": lambda x, y: y / (x * x + y * y),
}
# offsets (in cells) away from the singular cell, and a non-square cell shape
OFFSETS = [(1, 0), (0, 1), (-1, 0), (-2, 1), (3, -2), (1, 1), (5, 7), (-9, 4), (20, -13)]


@pytest.mark.parametrize("name", list(ELEMENTARY))
@pytest.mark.parametrize("half", [(0.5, 0.5), (0.5, 0.3)])
def test_closed_form_matches_quadrature(name, half):
    """Each closed-form cell integral equals adaptive quadrature of the point kernel to 1e-8."""
    a, b = half
    f = ELEMENTARY[name]
    for ox, oy in OFFSETS:
        X, Y = 2 * a * ox, 2 * b * oy
        ref, err = integrate.dblquad(lambda y, x: f(x, y), X - a, X + a, Y - b, Y + b, epsabs=1e-14, epsrel=1e-12)
        got = cell_integral(name, np.float64(X), np.float64(Y), a, b)
        scale = max(abs(ref), 1e-3 * abs(cell_integral("inv_r", np.float64(X), np.float64(Y), a, b)))
        assert abs(got - ref) / scale < 1e-8, f"{name} at offset {(ox, oy)}: closed {got!r} vs quadrature {ref!r}"


def test_singular_cell_of_love():
    """Love (1929): the integral of 1/r over a square of side 2a about its centre is 8 a asinh(1)."""
    assert cell_integral("inv_r", 0.0, 0.0, 0.5, 0.5) == pytest.approx(4 * np.arcsinh(1.0), rel=1e-14)
    assert cell_integral("x_r2", 0.0, 0.0, 0.5, 0.5) == 0.0  # odd kernel: no self term


@pytest.mark.parametrize("padded", [False, True])
def test_coefficients_are_the_cell_integrals(padded):
    """influence_coefficients evaluates each antiderivative once per cell corner and differences
    the corners; the result is cell_integral (checked against quadrature above) at every offset,
    in natural order or in the padded wrap-around layout (zero middle row and column), to 1e-12
    of the largest value (rounding of the corner differences at far offsets)."""
    ny, nx, dx, dy = 7, 10, 1.3e-9, 0.7e-9
    got = influence_coefficients(PAPER_PAIR, ny, nx, dx, dy, padded=padded)
    oy = np.arange(2 * ny) if padded else np.arange(-(ny - 1), ny)
    ox = np.arange(2 * nx) if padded else np.arange(-(nx - 1), nx)
    if padded:
        oy, ox = np.where(oy < ny, oy, oy - 2 * ny), np.where(ox < nx, ox, ox - 2 * nx)
    X, Y = np.meshgrid(ox * dx, oy * dy, indexing="xy")
    for name, terms in point_kernels(PAPER_PAIR).items():
        want = sum(c * cell_integral(e, X, Y, 0.5 * dx, 0.5 * dy) for c, e in terms)
        if padded:
            want[ny, :] = 0.0
            want[:, nx] = 0.0
        err = np.abs(got[name] - want).max() / np.abs(want).max()
        assert err < 1e-12, (name, err)


def test_antiderivatives_on_the_axes_and_at_the_origin():
    """The antiderivatives are finite on the axes and at the origin, where their terms' factors
    vanish (x asinh(y/|x|) at x = 0, y ln r at y = 0): the conventions the corner lattice and
    the singular cell rely on; off the axes they are the closed forms of the module docstring."""
    from warpcontact.physics.influence import _corner_terms

    v = np.array([-2.0, 0.0, 0.5]) * 1.3e-9
    X, Y = np.meshgrid(v, v, indexing="xy")
    with np.errstate(all="raise"):
        terms = _corner_terms(X, Y)
    for name, t in terms.items():
        assert np.all(np.isfinite(t)), name
        assert t[1, 1] == 0.0, name  # the origin
    x, y = -2.0e-9, 0.65e-9
    r = np.hypot(x, y)
    t = _corner_terms(np.float64(x), np.float64(y))
    assert t["inv_r"] == pytest.approx(x * np.arcsinh(y / abs(x)) + y * np.arcsinh(x / abs(y)), rel=1e-14)
    assert t["xy_r3"] == pytest.approx(-r, rel=1e-14)
    assert t["x_r2"] == pytest.approx(x * np.arctan(y / x) + y * np.log(r), rel=1e-14)
    assert t["y_r2"] == pytest.approx(y * np.arctan(x / y) + x * np.log(r), rel=1e-14)


@pytest.mark.parametrize("padded", [False, True])
def test_coefficients_by_blocks_on_threads_are_the_single_thread_ones(padded):
    """A grid of several row blocks (BLOCK_ROWS) gives the same coefficients, bit for bit, on one
    thread and on three, and the cell integrals at a few offsets across the blocks' seams."""
    from warpcontact.physics.influence import BLOCK_ROWS

    ny, nx, dx, dy = 2 * BLOCK_ROWS + 5, 37, 1.1e-9, 0.9e-9
    one = influence_coefficients(PAPER_PAIR, ny, nx, dx, dy, padded=padded, workers=1)
    three = influence_coefficients(PAPER_PAIR, ny, nx, dx, dy, padded=padded, workers=3)
    for k in KERNELS:
        np.testing.assert_array_equal(one[k], three[k], err_msg=k)
    half = (0.5 * dx, 0.5 * dy)
    for oy, ox in ((BLOCK_ROWS - ny, 3), (-1, -nx + 1), (0, 0), (BLOCK_ROWS - 1, 5), (ny - 1, nx - 1)):
        row = oy % (2 * ny) if padded else oy + ny - 1
        col = ox % (2 * nx) if padded else ox + nx - 1
        for name, terms in point_kernels(PAPER_PAIR).items():
            want = sum(c * cell_integral(e, ox * dx, oy * dy, *half) for c, e in terms)
            assert one[name][row, col] == pytest.approx(want, rel=1e-12, abs=1e-12 * abs(one[name]).max()), (name, oy, ox)


def _dense(op, n):
    """The assembled 3x3 operator as a dense (3 n^2, 3 n^2) matrix, columns from unit tractions."""
    import warp as wp

    fields = [wp.zeros((n, n), dtype=op.dtype, device=op.device) for _ in range(6)]
    cols = []
    for comp in range(3):
        for idx in range(n * n):
            src = np.zeros((3, n * n))
            src[comp, idx] = 1.0
            for k in range(3):
                fields[k].assign(src[k].reshape(n, n))
            op.coupled_apply(*fields[:3], *fields[3:])
            cols.append(np.concatenate([fields[k].numpy().ravel() for k in (3, 4, 5)]))
    return np.array(cols).T


def test_assembled_operator_is_symmetric_and_positive(device):
    """Reciprocity: K_xz[i, j] = K_zx[j, i]; the whole 3x3 operator is symmetric positive definite."""
    n = 8
    op = ElasticOperator(PAPER_PAIR, Grid(n, 1e-8), device, __import__("warp").float64, "auto")
    K = _dense(op, n)
    assert np.max(np.abs(K - K.T)) < 1e-12 * np.max(np.abs(K))
    assert np.linalg.eigvalsh(0.5 * (K + K.T)).min() > 0


def test_identical_materials_decouple(device):
    """D = 0 for identical bodies: a shear gives no normal displacement, a pressure no tangential."""
    import warp as wp

    pair = MaterialPair(COPPER, COPPER)
    assert pair.D == 0.0
    n = 16
    op = ElasticOperator(pair, Grid(n, 1e-8), device, wp.float64, "auto")
    rng = np.random.default_rng(0)
    p, qx, qy = (wp.array(rng.random((n, n)), dtype=wp.float64, device=device) for _ in range(3))
    uz, ux, uy = (wp.zeros((n, n), dtype=wp.float64, device=device) for _ in range(3))
    op.cross_normal(qx, qy, uz)
    op.cross_tangential(p, ux, uy)
    assert np.abs(uz.numpy()).max() < 1e-14 and np.abs(ux.numpy()).max() < 1e-14


def test_sign_of_coupling():
    """Frictionless pressure: the body with the larger (1 - 2 nu)/G (copper, the sphere) moves
    towards the contact centre relative to the other (MODEL.md section 2)."""
    assert (1 - 2 * COPPER.nu) / COPPER.G > (1 - 2 * HARDENED_STEEL.nu) / HARDENED_STEEL.G
    n = 9
    coeff = influence_coefficients(PAPER_PAIR, n, n, 1.0, 1.0, padded=False)
    xz = coeff["xz"]  # u_t = u_flat - u_sphere at offset (x, y) from a loaded cell
    c = n - 1  # index of offset 0
    # sphere relative to flat = -u_t: negative (towards the centre) at x > 0, positive at x < 0
    assert -xz[c, c + 3] < 0 and -xz[c, c - 3] > 0
    assert xz[c + 3, c] == pytest.approx(0.0, abs=1e-30)  # no x-displacement on the y axis


@pytest.mark.parametrize("n", [8, 9, 13])
def test_dcfft_matches_direct_summation(n, device):
    """DC-FFT (zero padding, wrap-around kernels) equals direct summation, no periodic images: the
    3x3 operator, its coupling terms alone (``cross_normal``, ``cross_tangential``), and the
    operator without its ZZ block (``coupled_shear``: K_tp p + K_tt q and K_zt q)."""
    import warp as wp

    dx = 1.3e-9
    op = ElasticOperator(PAPER_PAIR, Grid(n, n * dx), device, wp.float64, "auto")
    rng = np.random.default_rng(n)
    t = rng.standard_normal((3, n, n))
    coeff = influence_coefficients(PAPER_PAIR, n, n, dx, dx, padded=False)
    scale = PAPER_PAIR.E_star / dx
    K = {k: coeff[k] * scale for k in KERNELS}
    kern = {
        ("z", 0): K["zz"], ("z", 1): -K["xz"], ("z", 2): -K["yz"],
        ("x", 0): K["xz"], ("x", 1): K["xx"], ("x", 2): K["xy"],
        ("y", 0): K["yz"], ("y", 1): K["xy"], ("y", 2): K["yy"],
    }
    part = {}  # (component, source): the displacement u_c of traction t_s alone
    for (c, s), k in kern.items():
        part[(c, s)] = np.zeros((n, n))
        for i in range(n):
            for j in range(n):
                # u[i, j] = sum_{k, l} K[i - k, j - l] t[k, l]; offsets index as n - 1 + d
                offsets = (n - 1 + i - np.arange(n)[:, None], n - 1 + j - np.arange(n)[None, :])
                part[(c, s)][i, j] = np.sum(k[offsets] * t[s])
    ref = {c: part[(c, 0)] + part[(c, 1)] + part[(c, 2)] for c in "zxy"}
    src = [wp.array(t[s], dtype=wp.float64, device=device) for s in range(3)]
    dst = [wp.zeros((n, n), dtype=wp.float64, device=device) for _ in range(3)]

    def check(what, c, computed, expected):
        err = np.abs(computed.numpy() - expected).max() / np.abs(expected).max()
        assert err < 1e-12, f"{what} u_{c}: DC-FFT differs from direct summation by {err:.2e}"

    op.coupled_apply(*src, *dst)
    for c, d in zip("zxy", dst):
        check("coupled", c, d, ref[c])
    # the coupling terms alone, as a turn of the coupled solver makes them
    op.cross_normal(src[1], src[2], dst[0])
    check("K_zt q", "z", dst[0], part[("z", 1)] + part[("z", 2)])
    op.cross_tangential(src[0], dst[1], dst[2])
    check("K_tp p", "x", dst[1], part[("x", 0)])
    check("K_tp p", "y", dst[2], part[("y", 0)])
    op.coupled_shear(*src, *dst)
    check("K_zt q", "z", dst[0], part[("z", 1)] + part[("z", 2)])
    check("K_tp p + K_tt q", "x", dst[1], ref["x"])
    check("K_tp p + K_tt q", "y", dst[2], ref["y"])


def test_kernel_table_is_complete():
    assert set(point_kernels(PAPER_PAIR)) == set(KERNELS)


#: (parity in x, parity in y) of each kernel: +1 even, -1 odd (MODEL.md section 2: x/r^3 terms odd
#: in x, and so on)
PARITY = {"zz": (1, 1), "xx": (1, 1), "yy": (1, 1), "xy": (-1, -1), "xz": (-1, 1), "yz": (1, -1)}


@pytest.mark.parametrize("shape", [(16, 16, 1.0, 1.0), (12, 20, 1.0, 1.5), (64, 64, 2.0, 2.0)])
def test_spectra_are_real_or_imaginary(shape):
    """The operator keeps one part of each influence spectrum (SPECTRUM_PARTS): that is right
    because each kernel is even or odd in x and in y on the padded grid, in wrap-around order.
    Both checked: the coefficients' parity, and the dropped part of the spectrum. Tolerances:
    the coefficients of far cells are differences of antiderivatives that grow like r log r, each
    rounded to 1e-16 relative; measured 1e-15 to 4e-14 of the largest coefficient at n <= 64
    (7e-13 at n = 256), and the dropped part 1e-16 to 1.1e-14 of the spectrum's largest entry."""
    from warpcontact.physics.influence import SPECTRUM_PARTS

    ny, nx, dx, dy = shape
    coeffs = influence_coefficients(PAPER_PAIR, ny, nx, dx, dy)
    for k in KERNELS:
        a = coeffs[k]
        px, py = PARITY[k]
        mirrored_x = np.roll(a[:, ::-1], 1, axis=1)  # a at offset (i, -j)
        mirrored_y = np.roll(a[::-1, :], 1, axis=0)
        scale = np.abs(a).max()
        assert np.abs(mirrored_x - px * a).max() < 1e-12 * scale, k
        assert np.abs(mirrored_y - py * a).max() < 1e-12 * scale, k
        spectrum = np.fft.rfft2(a)
        kept, dropped = ((spectrum.real, spectrum.imag) if SPECTRUM_PARTS[k] == "real"
                         else (spectrum.imag, spectrum.real))
        assert SPECTRUM_PARTS[k] == ("real" if px == py else "imag"), k
        assert np.abs(dropped).max() < 1e-13 * np.abs(kept).max(), k


def _energy_backends():
    """(fft name, device, cupy layout) for every backend on this machine."""
    import warp as wp

    from warpcontact.fft import cupy_backend

    out = [pytest.param("fftw", "cpu", None, marks=NEEDS_FFTW), ("scipy", "cpu", None), ("warp", "cpu", None)]
    for i in range(wp.get_cuda_device_count()):
        out.append(pytest.param("warp", f"cuda:{i}", None, marks=pytest.mark.gpu))
        if cupy_backend.available():
            out += [pytest.param("cupy", f"cuda:{i}", pruned, marks=pytest.mark.gpu) for pruned in (True, False)]
    return out


@pytest.mark.parametrize("inverse", [False, True])
@pytest.mark.parametrize("n", [12, 17])
@pytest.mark.parametrize("dtype", ["float64", "float32"])
@pytest.mark.parametrize("fft,device,pruned", _energy_backends())
def test_normal_energy_in_fourier_space_is_the_real_space_sum(fft, device, pruned, dtype, n, inverse):
    """normal_padded(energy, slot) sums (K t) . t by Parseval during the spectral product: it must
    equal the sum over the grid of t times the K t it leaves in the padded output, in every
    backend's layout (scipy and cupy: rfft along x; warp: transposed, power-of-two padding), and
    leave that K t as the plain product does. Tolerance: float64 1e-12, float32 2e-5 relative (both
    sides come from the same transforms; each carries their rounding, ~eps log2(points) ~ 1e-15
    and 1e-6). A wrong Parseval weight on the half axis's end entries (1 against 2) shows at the
    ~1 / n level. With ``inverse`` (the preconditioner's product, 1 / K in Fourier space) the same
    for t . (M t), and M t is the circulant inverse computed with NumPy on the 2 n padded grid
    (all backends but warp, whose padded grid is a power of two: another circulant)."""
    import warp as wp

    from warpcontact.fft.cupy_backend import CupyFFT

    wdtype = getattr(wp, dtype)
    grid = Grid(n, 1e-8)
    op = ElasticOperator(PAPER_PAIR, grid, device, wdtype, fft)
    if pruned is not None:
        op.fft = CupyFFT(n, n, device, wdtype, pruned=pruned)
    f = op.fft
    rng = np.random.default_rng(n)
    t = rng.standard_normal((n, n))
    t[rng.random((n, n)) < 0.3] = 0.0  # a free set with holes, as in a solve
    t = t.astype(f.np_real).astype(np.float64)  # the field as the backend holds it
    padded = np.zeros(f.padded_input.shape)
    padded[:n, :n] = t
    f.padded_input.assign(padded.astype(f.np_real))
    energy = wp.zeros(3, dtype=wdtype, device=device)
    op.normal_padded(energy, 1, inverse=inverse)
    out = f.padded_output.numpy()[:n, :n].astype(np.float64) * float(f.output_scale)  # K t, or M t
    tol = 1e-12 if dtype == "float64" else 2e-5
    got = energy.numpy().astype(np.float64)
    assert got[1] == pytest.approx(float(np.sum(out * t)), rel=tol)
    assert got[1] > 0 and got[0] == 0.0 and got[2] == 0.0  # K and M are positive definite
    if not inverse:
        want = wp.zeros((n, n), dtype=wdtype, device=device)
        op.normal(wp.array(t.astype(f.np_real), dtype=wdtype, device=device), want)
        want = want.numpy()
    elif fft != "warp":
        # the coefficients the operator was built from: on CUDA the device path's, which differ from
        # the host's by up to ~1e-11 of the largest (rounding of the four-corner differences of far
        # cells, bench/setup_time.py), more than this check's 1e-12 once divided in by 1 / K
        if op.influence_path == "device":
            zz = influence_coefficients_device(PAPER_PAIR, n, n, grid.dx, grid.dy, device)["zz"].numpy()
        else:
            zz = influence_coefficients(PAPER_PAIR, n, n, grid.dx, grid.dy)["zz"]
        coefficients = zz * PAPER_PAIR.E_star / grid.dx
        full = np.zeros((2 * n, 2 * n))
        full[:n, :n] = t
        want = np.fft.irfft2(np.fft.rfft2(full) / np.fft.rfft2(coefficients).real, s=full.shape)[:n, :n]
    else:
        return
    assert np.abs(out - want).max() <= tol * np.abs(out).max()


@pytest.mark.parametrize("inverse", [False, True])
@pytest.mark.parametrize("fft", [pytest.param("fftw", marks=NEEDS_FFTW), "scipy", "warp"])
def test_spectral_energy_split_over_cpu_threads_is_the_whole_one(fft, inverse):
    """On the CPU the spectral product with its Parseval sum is split by rows over the threads
    (``launch.FirstRow`` gives each part its first row, which the Parseval weight needs where the
    half axis runs along the rows: the warp backend). Split and whole launches must give the same
    product and the same sum up to the order of the additions (1e-12 relative, float64); the
    split threshold set to 0, so that the n = 200 grid is split."""
    import warp as wp

    n = 200
    op = ElasticOperator(PAPER_PAIR, Grid(n, 1e-8), "cpu", wp.float64, fft)
    spectra = op.fft.alloc_spectra(2)
    rng = np.random.default_rng(3)
    values = rng.standard_normal((*op.fft.spectral_shape, 2))
    results = []
    op.launches.min_split_entries = 0
    for part, workers in enumerate((1, 2)):
        op.launches.workers = workers
        spectra[part].assign(values)
        energy = wp.zeros(1, dtype=wp.float64, device="cpu")
        op.normal_product(spectra[part], energy, 0, inverse=inverse)
        results.append((spectra[part].numpy(), float(energy.numpy()[0])))
    (whole, e1), (split, e2) = results
    assert op.launches._splits  # split plans were made
    assert np.array_equal(whole, split)
    assert e2 == pytest.approx(e1, rel=1e-12) and e1 > 0


@pytest.mark.parametrize("fft", ["scipy", "warp"])
def test_spectral_energy_reads_the_mirror_of_its_even_spectrum(fft):
    """K_zz is even, so its spectrum is too along the full axis (the one the real transform does
    not halve): with ``mirror`` (CUDA's launch) the energy product reads only the entries up to
    the middle of that axis. Checked on the CPU in one whole launch, for both layouts (full axis
    along the rows: scipy; along the columns: the warp backend): with the entries past the middle
    set to NaN the product and its sum are those of the stored spectrum to 1e-13 (the stored
    halves agree to the rounding of the transform that made them) and finite; without
    ``mirror`` they are NaN (the test can fail)."""
    import warp as wp

    from warpcontact.kernels import spectral
    from warpcontact.numerics.launch import ReductionLaunch

    n = 24
    op = ElasticOperator(PAPER_PAIR, Grid(n, 1e-8), "cpu", wp.float64, fft)
    fft_ = op.fft
    full_axis = 1 - fft_.half_axis
    length = fft_.spectral_shape[full_axis]
    rng = np.random.default_rng(5)
    values = rng.standard_normal((*fft_.spectral_shape, 2))
    influence = op.influence.numpy()
    poisoned = influence.copy()
    past = [slice(None)] * 3
    past[0] = 0  # ZZ
    past[1 + full_axis] = slice(length // 2 + 1, None)
    poisoned[tuple(past)] = np.nan
    entries = int(np.prod(fft_.spectral_shape))
    shape = ReductionLaunch.for_cells(entries, fft_.device)

    def product(table, mirror):
        spectrum = wp.array(values, dtype=fft_.complex_dtype, device="cpu")
        energy = wp.zeros(1, dtype=wp.float64, device="cpu")
        op.launches.launch_reduce(
            spectral.spectral_normal_energy, shape, entries,
            [wp.array(table, dtype=wp.float64, device="cpu"), spectrum, fft_.half_axis, fft_.half_length,
             fft_.energy_scale, 0, 0, 0, mirror], [energy])
        return spectrum.numpy(), float(energy.numpy()[0])

    (want, e_want), (got, e_got) = product(influence, 0), product(poisoned, length)
    assert np.isfinite(got).all() and np.isfinite(e_got)
    assert np.abs(got - want).max() <= 1e-13 * np.abs(want).max()
    assert e_got == pytest.approx(e_want, rel=1e-13)
    assert np.isnan(product(poisoned, 0)[1])


@pytest.mark.parametrize("inverse", [False, True])
@pytest.mark.parametrize("fft,device,pruned", _energy_backends())
def test_spectral_energy_of_a_grid_with_several_entries_per_thread(fft, device, pruned, inverse):
    """As above at n = 300 in float64: on CUDA the spectrum (600 x 301 entries, more than the
    launch's 4 blocks per SM of 256 threads) makes each thread visit several entries, whose (row,
    column) the kernel carries from one to the next instead of dividing (``spectral_normal_energy``);
    on the CPU the launch is split by rows over the threads."""
    test_normal_energy_in_fourier_space_is_the_real_space_sum(fft, device, pruned, "float64", 300, inverse)


# --- the device path (kernels/influence.py, influence.device_coefficients) ---------------------

#: rounding allowance of one cell's four-corner difference, in units of eps times the sum over its
#: corners of the magnitudes of the antiderivative's terms (``_corner_magnitudes``). Each side
#: evaluates a term to a few ulp (numpy's libm asinh, atan, log: <= 1 ulp; the kernels' asinh,
#: log1p by Goldberg's compensation: <= 3 ulp; the argument's division and the product with x or
#: y: 1 ulp more), <= 4 eps per side and term, 8 for the two; the three subtractions of the
#: difference round on each side to <= eps / 2 of the running sum: 3 more. 16 leaves a margin
#: over these 11; measured on the CPU: 1.22 at most (0.076 of the bound; n = 8 ... 256, square and
#: non-square cells). A far cell's integral is about (2 n)^2 times smaller than these magnitudes
#: (the antiderivatives grow like r, the cell integral falls like 1/r), so relative to the largest
#: coefficient the differences are 1.4e-15 (n = 8) to 4.2e-14 (n = 64), 3.4e-13 (n = 256).
CORNER_ROUNDING_ULPS = 16


def _corner_magnitudes(x, y) -> dict:
    """Per elementary kernel, the sum of the magnitudes of its antiderivative's terms at the
    corners (x, y) (``_corner_terms``' formulas without their signs and cancellations)."""
    from warpcontact.physics.influence import _xasinh

    xa, ya = np.abs(_xasinh(x, y)), np.abs(_xasinh(y, x))
    r2 = x * x + y * y
    safe_r2, safe_x, safe_y = np.where(r2 > 0, r2, 1.0), np.where(x != 0, x, 1.0), np.where(y != 0, y, 1.0)
    half_log = np.where(r2 > 0, 0.5 * np.abs(np.log(safe_r2)), 0.0)
    x_atan = np.where(x != 0, np.abs(x * np.arctan(y / safe_x)), 0.0)
    y_atan = np.where(y != 0, np.abs(y * np.arctan(x / safe_y)), 0.0)
    return {"inv_r": xa + ya, "xx_r3": ya, "yy_r3": xa, "xy_r3": np.sqrt(r2),
            "x_r2": x_atan + np.abs(y) * half_log, "y_r2": y_atan + np.abs(x) * half_log}


def _rounding_bound(pair, ny, nx, dx, dy, padded=True) -> dict:
    """Per kernel, the allowed |device - host| of each coefficient (CORNER_ROUNDING_ULPS eps times
    sum_terms |c| sum_corners magnitudes), in the coefficients' layout."""
    from warpcontact.physics.influence import _layout

    first_y, first_x, count_y, count_x = _layout(ny, nx, padded)
    cy = (np.arange(count_y + 1, dtype=np.float64) - first_y - 0.5) * dy
    cx = (np.arange(count_x + 1, dtype=np.float64) - first_x - 0.5) * dx
    mags = _corner_magnitudes(cx[None, :], cy[:, None])
    cells = {e: m[1:, 1:] + m[:-1, 1:] + m[1:, :-1] + m[:-1, :-1] for e, m in mags.items()}
    eps = np.finfo(np.float64).eps
    out = {}
    for name, terms in point_kernels(pair).items():
        bound = CORNER_ROUNDING_ULPS * eps * sum(abs(c) * cells[e] for c, e in terms)
        out[name] = np.roll(bound, (-first_y, -first_x), axis=(0, 1)) if padded else bound
    return out


#: (n, dx, dy): even and odd n, square and non-square cells
DEVICE_SHAPES = [(8, 1.3e-9, 1.3e-9), (9, 1.3e-9, 0.7e-9), (13, 1e-8, 1e-8), (64, 1e-8, 1e-8), (64, 0.6e-9, 1.1e-9)]


@pytest.mark.parametrize("padded", [True, False])
@pytest.mark.parametrize("n,dx,dy", DEVICE_SHAPES)
def test_device_coefficients_are_the_numpy_ones(n, dx, dy, padded, device):
    """The Warp kernels' coefficients (kernels/influence.py) are the numpy path's, cell by cell,
    within the rounding of the four-corner difference (CORNER_ROUNDING_ULPS: the bound is per
    cell, from the magnitudes of its corners' terms), float64, in the same layout (the padded
    wrap-around order with its zero middle row and column, or natural order)."""
    import warp as wp

    host = influence_coefficients(PAPER_PAIR, n, n, dx, dy, padded=padded)
    got = influence_coefficients_device(PAPER_PAIR, n, n, dx, dy, device, padded=padded)
    bound = _rounding_bound(PAPER_PAIR, n, n, dx, dy, padded)
    assert list(got) == list(KERNELS)
    for k in KERNELS:
        assert got[k].dtype == wp.float64 and got[k].device == wp.get_device(device), k
        d = got[k].numpy()
        assert d.shape == host[k].shape, k
        err = np.abs(d - host[k])
        assert np.all(err <= bound[k]), (k, float((err / bound[k]).max()))
        if padded:
            assert np.all(d[n, :] == 0.0) and np.all(d[:, n] == 0.0), k


def test_device_coefficients_scale_and_order():
    """``scale`` multiplies the sum of the terms (as the operator's ``a *= scale``, rounded the
    same way), and the generator yields KERNELS in order, each made when asked for."""
    from warpcontact.physics.influence import device_coefficients, influence_coefficients_device

    n, dx = 9, 1.3e-9
    scale = PAPER_PAIR.E_star / dx
    plain = influence_coefficients_device(PAPER_PAIR, n, n, dx, dx, "cpu")
    scaled = dict(device_coefficients(PAPER_PAIR, n, n, dx, dx, "cpu", scale=scale))
    for k in KERNELS:
        np.testing.assert_array_equal(scaled[k].numpy(), plain[k].numpy() * scale, err_msg=k)
    gen = device_coefficients(PAPER_PAIR, n, n, dx, dx, "cpu")
    assert next(gen)[0] == KERNELS[0]
    assert [k for k, _ in gen] == list(KERNELS[1:])


def _influence_backends():
    """(fft name, device) of every backend on this machine, the CUDA ones marked gpu."""
    import warp as wp

    from warpcontact.fft import cupy_backend

    out = [pytest.param("fftw", "cpu", marks=NEEDS_FFTW), ("scipy", "cpu"), ("warp", "cpu")]
    for i in range(wp.get_cuda_device_count()):
        out.append(pytest.param("warp", f"cuda:{i}", marks=pytest.mark.gpu))
        if cupy_backend.available():
            out.append(pytest.param("cupy", f"cuda:{i}", marks=pytest.mark.gpu))
    return out


@pytest.mark.parametrize("dtype", ["float64", "float32"])
@pytest.mark.parametrize("n", [8, 9, 13, 64])
@pytest.mark.parametrize("fft,device", _influence_backends())
def test_operator_spectra_from_device_coefficients(fft, device, n, dtype):
    """ElasticOperator with influence="device" keeps the spectra, self-coefficients and column
    norms of influence="host", in every backend. The backends get float64 coefficients either
    way, whatever the model's float type (as the host path hands them over); the cupy backend
    gets Warp arrays on its device (no host copy), the others numpy arrays.

    Tolerance per spectrum: the coefficients' own allowance summed over the cells (a DFT weight
    has modulus 1), plus the two transforms' rounding, 2 x 2 log2(points) eps of sum |a| (the
    usual bound of a radix-2 FFT, with a factor 2 of margin), plus the cast to the model's float
    type of each side (eps of the largest entry). Measured on the CPU: 2.0e-14 of the largest
    entry (float64, n = 64), 0 in float32."""
    import warp as wp

    wdtype = getattr(wp, dtype)
    grid = Grid(n, n * 1.3e-9)
    host = ElasticOperator(PAPER_PAIR, grid, device, wdtype, fft, influence="host")
    received = []
    original = type(host.fft).influence_spectra

    def recording(self, arrays, parts, out, scratch):
        def seen():
            for a in arrays:
                if not self.periodic:  # (the preconditioners' periodic transforms: their spectra below)
                    received.append((type(a), a.dtype, getattr(a, "device", None)))
                yield a
        return original(self, seen(), parts, out, scratch)

    type(host.fft).influence_spectra = recording
    try:
        dev = ElasticOperator(PAPER_PAIR, grid, device, wdtype, fft, influence="device")
    finally:
        type(host.fft).influence_spectra = original
    assert host.influence_path == "host" and dev.influence_path == "device"
    assert len(received) == len(KERNELS)
    for kind, dt, where in received:
        if fft == "cupy":
            assert kind is wp.array and dt == wp.float64 and where == wp.get_device(device)
        else:
            assert kind is np.ndarray and dt == np.float64
    scale = PAPER_PAIR.E_star / grid.dx
    coeffs = influence_coefficients(PAPER_PAIR, n, n, grid.dx, grid.dy)
    bound = _rounding_bound(PAPER_PAIR, n, n, grid.dx, grid.dy)
    points = 4 * n * n
    eps = float(np.finfo(np.float64 if dtype == "float64" else np.float32).eps)
    want, got = host.influence.numpy().astype(np.float64), dev.influence.numpy().astype(np.float64)
    for i, k in enumerate(KERNELS):
        total = scale * np.abs(coeffs[k]).sum()
        tol = scale * bound[k].sum() + 4 * np.log2(points) * eps * total + eps * np.abs(want[i]).max()
        err = np.abs(got[i] - want[i]).max()
        assert err <= tol, (k, err, tol)
        assert dev.self_coefficient(k) == pytest.approx(host.self_coefficient(k), rel=1e-14, abs=1e-300), k
        assert dev.column_norm(k) == pytest.approx(host.column_norm(k), rel=1e-13), k
        # the preconditioners' circulants (T. Chan's on the grid itself) of the same coefficients:
        # each a convex combination of four of them per cell, so within the same allowance, on a
        # transform of fewer points
        if i < len(PRECONDITIONER_KERNELS) and host.has_periodic_preconditioner:
            want_c, got_c = (op.inverse_transforms(periodic=True).influence.numpy()[i].astype(np.float64)
                             for op in (host, dev))
            err = np.abs(got_c - want_c).max()
            assert err <= tol, ("periodic", k, err, tol)


def test_influence_path_default_and_refusal():
    """"auto" is the host (numpy) on the CPU; a wrong name is an InputError naming ``influence``."""
    import warp as wp

    from warpcontact.errors import InputError

    assert ElasticOperator(PAPER_PAIR, Grid(8, 1e-8), "cpu", wp.float64, "scipy").influence_path == "host"
    with pytest.raises(InputError, match="^influence: unknown path 'gpu'"):
        ElasticOperator(PAPER_PAIR, Grid(8, 1e-8), "cpu", wp.float64, "scipy", influence="gpu")


@pytest.mark.parametrize("dtype", ["float64", "float32"])
def test_cupy_backend_loads_device_coefficients_by_a_cast(dtype):
    """The cupy backend's input load (``cupy_backend._load``) casts a float64 Warp array on its
    device into the buffer's float type, row halves as views, as numpy casts a host array: the
    same values (round to nearest both). Checked with CPU arrays (the function is device-blind)."""
    import warp as wp

    from warpcontact.fft.cupy_backend import CupyFFT, _load

    rng = np.random.default_rng(1)
    values = rng.standard_normal((6, 10)) * 1e-3
    src = wp.array(values, dtype=wp.float64, device="cpu")
    for rows in (slice(0, 3), slice(3, 6), slice(0, 6)):
        dst = wp.zeros((rows.stop - rows.start, 10), dtype=getattr(wp, dtype), device="cpu")
        _load(dst, src[rows])
        np.testing.assert_array_equal(dst.numpy(), values[rows].astype(dtype))
    assert CupyFFT.takes_device_coefficients


@pytest.mark.parametrize("n", [9, 64])
def test_batch_influence_spectra_made_on_each_device(n, device):
    """The batched solves' influence spectra (``fft.batch.scaled_influence``: Warp's coefficients
    and cuFFT on CUDA, numpy on the CPU) are the padded spectra, 2-norms, offset-(0, 0) values and
    T. Chan's circulants' spectra of the host's coefficients times the scale, recomputed here with
    numpy's full complex transform. Tolerance 1e-12 of each spectrum's largest entry: float64
    transforms of at most 128^2 points round to about eps log2(128^2) = 3e-15 of it, and the
    coefficients agree cell by cell to their corners' rounding (above). Only the kernels asked
    for come back, a circulant only where asked for."""
    from warpcontact.fft import cupy_backend
    from warpcontact.fft.batch import scaled_influence
    from warpcontact.physics.influence import chan_circulant

    if device.startswith("cuda") and not cupy_backend.available():
        pytest.skip("the batched solves on CUDA need CuPy, which is not installed")
    scale = PAPER_PAIR.E_star
    host = influence_coefficients(PAPER_PAIR, n, n, 1.0, 1.0)
    got = scaled_influence(PAPER_PAIR, n, device, ("xx", "xz", "zz"), ("xx",), scale)
    assert sorted(got) == ["xx", "xz", "zz"]
    for k, (spectrum, norm, origin, circulant) in got.items():
        a = host[k] * scale
        want = np.fft.fft2(a)[:, : n + 1]
        assert spectrum.shape == want.shape == (2 * n, n + 1), k
        peak = np.abs(want).max()
        assert np.abs(spectrum - want).max() <= 1e-12 * peak, k
        assert norm == pytest.approx(np.sqrt(np.sum(a * a)), rel=1e-12), k
        assert origin == pytest.approx(a[0, 0], rel=1e-12), k
        if k == "xx":
            want_c = np.fft.fft2(chan_circulant(a))[:, : n // 2 + 1].real
            assert np.abs(circulant - want_c).max() <= 1e-12 * np.abs(want_c).max()
        else:
            assert circulant is None, k
    assert list(scaled_influence(PAPER_PAIR, n, device, ("zz",))) == ["zz"]
