"""Large grids on a GPU: a whole load path without the nested start, and the yield check at
n = 8192 (its stacked spectra pass 2^31 bytes there: Warp's 32-bit strides, ``SubsurfaceStress``).

CUDA only; the CPU's share of the same methods is tests/test_warm_start.py."""

import math
from pathlib import Path

import numpy as np
import pytest
import warp as wp

try:
    import tomllib
except ModuleNotFoundError:  # Python 3.10
    import tomli as tomllib

from conftest import DEVICES

CUDA = [d for d in DEVICES if d.startswith("cuda")] or [
    pytest.param("cuda", marks=pytest.mark.skip(reason="no CUDA device here"))]
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.mark.gpu
@pytest.mark.parametrize("device", CUDA)
def test_figure2c_path_at_2048_without_the_nested_start(device):
    """examples/figure2c.toml at n = 2048, the nested start off: all 16 states converge, none over
    1000 inner iterations (H100: largest 331, at n = 256 88; the warm-started normal solves diverged
    at 2000 iterations a state before they stepped the penetrating cells with the free set)."""
    import warpcontact as wc

    with open(EXAMPLES / "figure2c.toml", "rb") as f:
        d = tomllib.load(f)
    d["grid"]["n"] = 2048
    d["solver"].update({"device": device, "nested": False})
    states = wc.solve(d, fields="none").states
    iterations = [s["iterations"] for s in states]
    assert len(states) == 16 and all(s["converged"] for s in states), f"iterations {iterations}"
    assert max(iterations) <= 1000, f"a state took {max(iterations)} inner iterations: {iterations}"


@pytest.mark.gpu
@pytest.mark.parametrize("device", CUDA)
def test_yield_check_at_8192(device):
    """The yield check of a Hertz pressure at n = 8192 in float64 (about 55 GiB on the device): the
    sphere's largest von Mises stress is Hertz's 0.6063 p0 within 1e-3 (the grid's and the depth
    search's discretisation; measured 1.3e-4 on an H100). Skipped where the device lacks the memory."""
    from warpcontact.numerics.stress import memory_bytes
    from warpcontact.numerics.stress_reference import hertz_von_mises_max
    from warpcontact.numerics.yielding import yield_check
    from warpcontact.physics.geometry import Grid
    from warpcontact.physics.materials import PAPER_PAIR

    n, radius, dz = 8192, 10e-6, 1e-10
    free = wp.get_device(device).free_memory
    need = memory_bytes(n, wp.float64, "cupy", 1)["device"]
    if need > 0.9 * free:
        pytest.skip(f"the yield check at n = {n} needs {need / 2**30:.0f} GiB, {free / 2**30:.0f} GiB free")
    a = math.sqrt(radius * dz)
    grid = Grid(n, 4 * a)
    x, y = np.meshgrid(grid.x, grid.y, indexing="xy")
    p0 = 2 * PAPER_PAIR.E_star * a / (math.pi * radius)
    p = p0 * np.sqrt(np.clip(1 - (x**2 + y**2) / a**2, 0, None))
    zero = np.zeros_like(p)
    out = yield_check(PAPER_PAIR, grid, {"pressure": p, "shear_x": zero, "shear_y": zero}, device=device)
    expected = hertz_von_mises_max(PAPER_PAIR.sphere.nu)[0]
    assert out["sphere"]["von_mises_max"] / p0 == pytest.approx(expected, rel=1e-3), out
