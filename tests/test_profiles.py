"""Shapes beyond the sphere ([sphere] profile, docs/surfaces.md): a sphere given as a height map
is the sphere to round-off; a sharp flat punch against Boussinesq and a sharp cone against Love
at two grids, the error falling; height maps on the nested start's coarse grid; every mistake in
a height map an InputError naming its key, and one line with exit 2 from the command line."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import warpcontact as wc
from warpcontact.errors import InputError
from warpcontact.physics.geometry import Grid
from warpcontact.records.case import case_from_dict, load_case

R = 10e-6  # m
DZ = 1e-10  # m: a = sqrt(R dz) = 31.6 nm
E, NU = 100e9, 0.3
E_STAR = E / (2.0 * (1.0 - NU * NU))  # two bodies of E, nu


def sphere_case(n: int, size: float, **sphere) -> dict:
    body = sphere or {"radius": R}
    return {"sphere": {**body, "E": E, "nu": NU}, "flat": {"E": E, "nu": NU}, "grid": {"n": n, "size": size},
            "load": {"delta_z": DZ}}


def sphere_map(tmp_path, n: int, size: float, name="sphere.npy", unit_factor=1.0) -> tuple[str, float]:
    """The exact sphere's gap R - sqrt(R^2 - r^2) on 2n + 1 pixels of dx / 2 per side: the pixel
    centres hold the origin and every cell centre of the n-cell grid (and of the n/2-cell grid)."""
    pixel = size / n / 2.0
    x = (np.arange(2 * n + 1) - n) * pixel
    r2 = x[:, None] ** 2 + x[None, :] ** 2
    h = r2 / (R + np.sqrt(R * R - r2)) / unit_factor
    path = tmp_path / name
    if name.endswith(".npy"):
        np.save(path, h)
    else:
        np.savetxt(path, h)
    return str(path), pixel


# ---------------------------------------------------------------------------------------------
# The sphere as a height map.


def test_sphere_as_a_height_map_is_the_sphere_to_round_off(tmp_path):
    """The map sampled at the cell centres is the exact sphere's gap (relative 1e-12 of its
    largest value), on the case's grid and on the half grid of the nested start (the model's
    on_grid), from a .npy in m and from a text grid in nm."""
    n, size = 32, 4.0 * math.sqrt(R * DZ)
    sphere = case_from_dict(sphere_case(n, size))
    for name, unit, factor in (("sphere.npy", "m", 1.0), ("sphere.txt", "nm", 1e-9)):
        path, pixel = sphere_map(tmp_path, n, size, name, factor)
        mapped = case_from_dict(sphere_case(n, size, profile="height_map", height_map=path, pixel_size=pixel,
                                            height_unit=unit))
        for grid in (mapped.grid, Grid(n // 2, size)):
            exact, from_map = sphere.sphere.initial_gap(grid), mapped.sphere.initial_gap(grid)
            assert np.max(np.abs(from_map - exact)) < 1e-12 * exact.max(), (name, grid.n)
    from warpcontact.numerics.model import ContactModel

    model = ContactModel(mapped.pair, mapped.sphere, mapped.grid)
    coarse = model.on_grid(Grid(n // 2, size))  # the nested start's coarse model
    expected = sphere.sphere.initial_gap(coarse.grid) / coarse.length_scale
    assert np.max(np.abs(coarse.initial_gap.numpy() - expected)) < 1e-12 * expected.max()


def test_sphere_as_a_height_map_gives_the_spheres_forces(tmp_path):
    """A frictionless solve (n = 32) and a frictional nested one (n = 64, nested = true: the map
    resampled to the 32-cell grid): the same forces as profile = "sphere"."""
    size = 4.0 * math.sqrt(R * DZ)
    for n, extra in ((32, {}), (64, {"friction": {"law": "coulomb", "mu": 0.3}, "solver": {"nested": True},
                                     "load": {"delta_z": DZ, "delta_x": 2e-11}})):
        path, pixel = sphere_map(tmp_path, n, size, f"s{n}.npy")
        forces = []
        for sphere in ({"radius": R}, {"profile": "height_map", "height_map": path, "pixel_size": pixel}):
            d = {**sphere_case(n, size, **sphere), **extra}
            result = wc.solve(case_from_dict(d), fields="none")
            forces.append([s["force"] for s in result.states])
        for a, b in zip(*forces):
            for k in ("x", "y", "z"):
                assert b[k] == pytest.approx(a[k], rel=1e-9, abs=1e-12 * abs(a["z"])), (n, k)


# ---------------------------------------------------------------------------------------------
# Closed forms of the other profiles.


def test_flat_punch_against_boussinesq():
    """A sharp rigid-edged flat punch of radius a pressed by delta_z: F = 2 a E* delta_z
    (Boussinesq 1885; Johnson 1985, section 3.8). The cells take the punch as those whose centre
    lies within a; the pressure's edge singularity p ~ (a - r)^(-1/2) is resolved to about a cell,
    so the force carries an error of order dx / a: against the punch of the cells' own area
    (radius a_cells = sqrt(N dx^2 / pi)) within dx / (4 a), against the nominal a within dx / (2 a)
    (half a cell of radius), and falling with the grid. Measured: -0.85 %, -0.41 % (a_cells) at
    dx / a = 0.078, 0.039."""
    a, dz = 10e-9, DZ
    errors = []
    for n in (32, 64):
        case = case_from_dict(sphere_case(n, 2.5 * a, profile="flat_punch", radius=a))
        F = wc.solve(case, fields="none").states[-1]["force"]["z"]
        gap = case.sphere.initial_gap(case.grid)
        a_cells = math.sqrt(np.count_nonzero(gap == 0.0) * case.grid.cell_area / math.pi)
        h = case.grid.dx / a
        err_cells = F / (2.0 * a_cells * case.pair.E_star * dz) - 1.0
        assert abs(err_cells) < 0.25 * h, (n, err_cells)
        assert abs(F / (2.0 * a * case.pair.E_star * dz) - 1.0) < 0.5 * h, n
        errors.append(abs(err_cells))
    assert errors[1] < 0.6 * errors[0], errors


def test_cone_against_love():
    """A sharp rigid cone of semi-angle alpha (between axis and surface) pressed by delta_z:
    a = 2 delta_z tan(alpha) / pi and F = (2 / pi) E* tan(alpha) delta_z^2 (Love 1939; Sneddon
    1965; Johnson 1985, section 5.6, with the cone's inclination beta = pi/2 - alpha: F = (pi/2)
    a^2 E* / tan(beta)). The pressure has only a logarithmic singularity at the tip and falls as
    sqrt(a - r) at the edge, like Hertz's, so the force converges at second order: within
    (dx / a)^2 (measured 2.6e-4 and 4.6e-5 at dx / a = 0.078, 0.039), and the contact radius
    within one cell."""
    alpha, dz = 80.0, 1e-10
    tan = math.tan(math.radians(alpha))
    a = 2.0 * dz * tan / math.pi
    errors = []
    for n in (32, 64):
        case = case_from_dict(sphere_case(n, 2.5 * a, profile="cone", half_angle=alpha))
        s = wc.solve(case, fields="none").states[-1]
        err = s["force"]["z"] / (2.0 / math.pi * case.pair.E_star * tan * dz * dz) - 1.0
        h = case.grid.dx / a
        assert abs(err) < h * h, (n, err)
        assert abs(math.sqrt(s["contact_area"] / math.pi) - a) < case.grid.dx, n
        errors.append(abs(err))
    assert errors[1] < 0.5 * errors[0], errors


def test_rounded_punch_and_cone_profiles():
    """The rounded edge and the rounded tip meet their flat and conical parts without a step or
    a kink: the gap at the joins, and the wall beyond the punch."""
    from warpcontact.physics.geometry import PUNCH_WALL_IN_RADII, Sphere

    a, rho = 1e-6, 2e-7
    punch = Sphere(a, "flat_punch", edge_radius=rho)
    r2 = np.array([(a - rho) ** 2, (a - rho / 2) ** 2, a * a, (1.01 * a) ** 2])
    h = punch._axisymmetric(r2)
    assert h[0] == 0.0 and h[1] == pytest.approx(rho - math.sqrt(rho**2 - (rho / 2) ** 2))
    assert h[2] == pytest.approx(rho) and h[3] == PUNCH_WALL_IN_RADII * a
    alpha, tip = math.radians(60.0), 1e-7
    cone = Sphere(profile="cone", half_angle=60.0, tip_radius=tip)
    rt = tip * math.cos(alpha)
    below, above = cone._axisymmetric(np.array([(rt * (1 - 1e-9)) ** 2, (rt * (1 + 1e-9)) ** 2]))
    assert below == pytest.approx(above, rel=1e-6)
    assert cone.radius == tip and cone.curvature_radius == tip and not cone.hertzian
    sharp = Sphere(profile="cone", half_angle=60.0)
    assert sharp._axisymmetric(np.array([4e-14]))[0] == pytest.approx(2e-7 / math.tan(alpha))


# ---------------------------------------------------------------------------------------------
# Height maps in a case file.


def _write_case(folder: Path, sphere: str, flat: str = "", grid: str = "n = 16\nsize = 1.6e-8",
                delta_z: float = 1e-10) -> Path:
    text = f"""[sphere]
{sphere}
E = 100e9
nu = 0.3

[flat]
E = 100e9
nu = 0.3
{flat}

[grid]
{grid}

[load]
delta_z = {delta_z!r}
"""
    p = folder / "case.toml"
    p.write_text(text)
    return p


def _bowl(n=16, m=None) -> np.ndarray:
    x = np.arange(n) - (n - 1) / 2
    y = np.arange(m or n) - ((m or n) - 1) / 2
    return 0.01 * (x[:, None] ** 2 + y[None, :] ** 2)  # nm, with pixel_size 1 nm


def test_relative_paths_units_grid_from_the_map_and_the_flats_map(tmp_path, monkeypatch):
    """A relative height_map is taken from the case file's folder (the run's folder elsewhere);
    grid n and size "map" take the map's pixels and side; the flat's map adds to the gap; the
    case round-trips through to_dict; the first axis runs along x."""
    folder = tmp_path / "cases"
    folder.mkdir()
    h = _bowl()
    h[15, 8] += 5.0  # a bump at the largest x (first axis), the middle of y
    np.save(folder / "bowl.npy", h)
    p = _write_case(folder, 'profile = "height_map"\nheight_map = "bowl.npy"\npixel_size = 1e-9\nheight_unit = "nm"',
                    grid='n = "map"\nsize = "map"')
    monkeypatch.chdir(tmp_path)
    case = load_case(p)
    assert case.grid.n == 16 and case.grid.size == pytest.approx(16e-9)
    gap = case.sphere.initial_gap(case.grid)
    assert np.allclose(gap, (h - h.min()).T * 1e-9, rtol=0, atol=1e-22)  # [row = y, column = x]
    assert gap[8, 15] == gap.max()
    assert case_from_dict(case.to_dict()) == case
    assert case.to_dict()["sphere"]["height_map"] == str(folder / "bowl.npy")
    np.save(folder / "flat.npy", np.ones((20, 20)) + np.arange(20)[:, None] * 0.1)
    rough = load_case(_write_case(folder, "radius = 1e-6", 'height_map = "flat.npy"\npixel_size = 1e-9\n'
                                  'height_unit = "nm"', delta_z=1e-11))
    X, Y = rough.grid.mesh()
    expected = (X**2 + Y**2) / (1e-6 + np.sqrt(1e-12 - X**2 - Y**2)) + (X / 1e-9 + 9.5) * 0.1e-9
    assert np.allclose(rough.sphere.initial_gap(rough.grid), expected, rtol=1e-9, atol=1e-24)
    assert not rough.sphere.hertzian and case_from_dict(rough.to_dict()) == rough


def _errors(folder: Path):
    """(sphere table, flat table, grid table, expected key) of each mistake a user can make."""
    np.save(folder / "ok.npy", _bowl())
    np.save(folder / "line.npy", np.arange(16.0))
    np.save(folder / "cube.npy", np.zeros((4, 4, 4)))
    np.save(folder / "wide.npy", _bowl(16, 20))
    np.save(folder / "strings.npy", np.array([["a", "b"], ["c", "d"]]))
    nan = _bowl()
    nan[3, 4] = np.nan
    np.save(folder / "nan.npy", nan)
    (folder / "junk.txt").write_text("1 2 3\n4 five 6\n")
    (folder / "junk.npy").write_bytes(b"not a numpy file")
    (folder / "a_folder.npy").mkdir(exist_ok=True)
    ok = 'profile = "height_map"\nheight_map = "ok.npy"\npixel_size = 1e-9'
    hm = 'profile = "height_map"\npixel_size = 1e-9\nheight_map = '
    return [
        (hm + '"missing.npy"', "", None, "sphere.height_map"),
        (hm + '"a_folder.npy"', "", None, "sphere.height_map"),
        (hm + '"line.npy"', "", None, "sphere.height_map"),
        (hm + '"cube.npy"', "", None, "sphere.height_map"),
        (hm + '"nan.npy"', "", None, "sphere.height_map"),
        (hm + '"junk.txt"', "", None, "sphere.height_map"),
        (hm + '"junk.npy"', "", None, "sphere.height_map"),
        (hm + '"strings.npy"', "", None, "sphere.height_map"),
        (hm + "3", "", None, "sphere.height_map"),
        (ok + '\nheight_unit = "furlong"', "", None, "sphere.height_unit"),
        ('profile = "height_map"\nheight_map = "ok.npy"\npixel_size = -1e-9', "", None, "sphere.pixel_size"),
        ('profile = "height_map"\nheight_map = "ok.npy"', "", None, "sphere.pixel_size"),
        ('profile = "height_map"\npixel_size = 1e-9', "", None, "sphere.height_map"),
        (ok, "", "n = 16\nsize = 2e-8", "sphere.height_map"),  # the domain reaches outside the 16 nm map
        ('height_map = "ok.npy"\npixel_size = 1e-9', "", None, "sphere.profile"),  # the profile left out
        ("radius = 1e-5", 'height_map = "ok.npy"\npixel_size = 0.5e-9', None, "flat.height_map"),  # 8 nm map
        ("radius = 1e-5", "pixel_size = 1e-9", None, "flat.height_map"),
        ("radius = 1e-5", 'height_map = "nan.npy"\npixel_size = 1e-9', None, "flat.height_map"),
        ("radius = 1e-5", "", 'n = "map"\nsize = 1.6e-8', "grid.n"),  # no map to take the grid from
        (hm + '"wide.npy"', "", 'n = 16\nsize = "map"', "grid.size"),  # not square
        ('radius = 1e-5\nhalf_angle = 60', "", None, "sphere.profile"),  # a cone's key, the profile left out
        ('profile = "sphere"\nradius = 1e-5\nhalf_angle = 60', "", None, "sphere.half_angle"),
        ('profile = "cone"\nhalf_angle = 90', "", None, "sphere.half_angle"),
        ('profile = "cone"', "", None, "sphere.half_angle"),
        ('profile = "flat_punch"\nradius = 5e-9\nedge_radius = 6e-9', "", None, "sphere.edge_radius"),
        ('profile = "flat_punch"\nradius = 5e-9\nedge_radius = -1e-9', "", None, "sphere.edge_radius"),
        ('profile = "flat_punch"\nradius = 1e-8', "", None, "grid.size"),  # the punch wider than the domain
        ('profile = "flat_punch"\nradius = 5e-10', "", "n = 16\nsize = 1.6e-9", "load.delta_z"),  # dz of a/5
    ]


def test_every_height_map_mistake_names_its_key(tmp_path):
    for sphere, flat, grid, key in _errors(tmp_path):
        p = _write_case(tmp_path, sphere, flat, *([grid] if grid else []))
        with pytest.raises(InputError) as e:
            load_case(p)
        assert e.value.key == key, (sphere, flat, grid, str(e.value))
        assert "\n" not in str(e.value)


def test_the_command_line_prints_one_line_and_exits_2(tmp_path):
    errors = _errors(tmp_path)
    for sphere, flat, grid, key in errors[:3] + errors[9:11]:
        p = _write_case(tmp_path, sphere, flat, *([grid] if grid else []))
        r = subprocess.run([sys.executable, "-m", "warpcontact.cli", "solve", str(p), "--out", str(tmp_path / "out"),
                            "--quiet"], capture_output=True, text=True, timeout=300)
        lines = [ln for ln in r.stderr.strip().splitlines() if not ln.startswith("Warp CUDA warning")]
        assert r.returncode == 2 and len(lines) == 1 and key in lines[0], r.stderr
        assert "Traceback" not in r.stderr


def test_no_hertz_number_for_other_shapes():
    """The closed forms of a sphere are left out, with the reason, for the other shapes."""
    from warpcontact.studies.fretting import closed_form_note

    d = sphere_case(32, 25e-9, profile="flat_punch", radius=10e-9)
    d["friction"] = {"law": "coulomb", "mu": 0.3}
    case = case_from_dict(d)
    assert not case.sphere.hertzian and "a flat punch" in closed_form_note(case)
    assert case.sphere.contact_radius(1e-11) == 10e-9 and case.sphere.curvature_radius == math.inf


# ---------------------------------------------------------------------------------------------
# Summaries of a contact of many patches.


def test_contact_patches_count_regions_joined_across_an_edge():
    """Cells in contact joined across an edge are one patch; cells that touch at a corner only
    are two (the grid resolves nothing between them)."""
    from warpcontact.records.results import contact_patches

    p = np.zeros((6, 6))
    p[1, 1] = p[1, 2] = p[2, 2] = 1.0  # one patch of three cells
    p[3, 3] = 2.0  # touches (2, 2) at a corner only: a second patch
    p[5, 0] = 0.5  # a third
    assert contact_patches(p) == 3
    assert contact_patches(np.zeros((4, 4))) == 0


def test_two_bumps_touch_in_two_patches(tmp_path):
    """A height map of two paraboloid bumps (R = 10 um each, 0.1 nm apart in height) pressed
    0.15 nm into the flat: both bumps touch, the summary counts two patches, and its mean gap is
    the mean of the gap field; the sphere's summary has no patch count (one contact by its shape)."""
    n, size = 64, 200e-9
    pixel = size / n
    x = (np.arange(n) - 0.5 * (n - 1)) * pixel
    X, Y = np.meshgrid(x, x, indexing="ij")
    bumps = np.minimum(((X + 50e-9) ** 2 + Y ** 2) / (2 * R), ((X - 50e-9) ** 2 + Y ** 2) / (2 * R) + 0.1e-9)
    path = tmp_path / "bumps.npy"
    np.save(path, bumps)
    d = sphere_case(n, size, profile="height_map", height_map=str(path), pixel_size=pixel)
    d["load"]["delta_z"] = 0.15e-9
    result = wc.solve(case_from_dict(d), fields="last")
    s = result.states[-1]
    assert s["converged"] and s["contact_patches"] == 2
    gap = result.fields[-1]["gap"]
    assert s["mean_gap"] == pytest.approx(float(gap.mean()), rel=1e-12, abs=1e-25)
    sphere = wc.solve(case_from_dict(sphere_case(32, 4.0 * math.sqrt(R * DZ))), fields="none")
    assert "contact_patches" not in sphere.states[-1] and sphere.states[-1]["mean_gap"] > 0


def test_a_grid_coarser_than_a_rough_maps_pixels_is_warned_of(tmp_path):
    """A rough map (H = 0.8, relief down to two pixels) read by cells of two pixels leaves out
    more than 1 % of its rms height: a PlausibilityWarning names grid.n and the n that reads every
    pixel. The same map on its own pixels, and the sphere's map read every other pixel (a smooth
    shape: about dx^2 / 8R left out), are not warned of."""
    import warnings

    from warpcontact.records.plausibility import PlausibilityWarning

    pixel, m = 1e-9, 64
    rough = wc.rough_surface(m, m * pixel, 0.8, rms_height=1e-9, seed=3)
    path = tmp_path / "rough.npy"
    np.save(path, rough)

    def warned(n: int, sphere_kw: dict, size: float) -> list[str]:
        with warnings.catch_warnings(record=True) as seen:
            warnings.simplefilter("always")
            case_from_dict(sphere_case(n, size, **sphere_kw))
        return [str(w.message) for w in seen if issubclass(w.category, PlausibilityWarning)]

    kw = {"profile": "height_map", "height_map": str(path), "pixel_size": pixel}
    coarse = warned(32, kw, m * pixel)
    assert len(coarse) == 1 and coarse[0].startswith("grid.n = 32 gives cells of 2e-9 m") and "grid.n = 64 reads" in coarse[0]
    assert warned(64, kw, m * pixel) == []
    n, size = 32, 4.0 * math.sqrt(R * DZ)
    sphere_path, sphere_pixel = sphere_map(tmp_path, n, size)
    assert warned(n, {"profile": "height_map", "height_map": sphere_path, "pixel_size": sphere_pixel}, size) == []


def test_a_height_map_body_may_touch_the_domains_edge(tmp_path):
    """A rigid rough indenter given as a height map over the whole domain, pressed until its
    contact reaches the edge: the body is its map (nothing beyond the domain), so the path solves
    without the sphere's grid.size error, and the summary counts its patches; with adhesion its
    tension on the edge is not taken for a tail the domain cuts."""
    pixel, n = 1e-9, 32
    np.save(tmp_path / "rough.npy", wc.rough_surface(n, n * pixel, 0.8, rms_slope=0.1, short_cutoff=4 * pixel, seed=2))
    d = {"sphere": {"profile": "height_map", "height_map": str(tmp_path / "rough.npy"), "pixel_size": pixel,
                    "rigid": True},
         "flat": {"E": E, "nu": NU}, "grid": {"n": n, "size": "map"}, "load": {"delta_z": 2e-9, "steps": 2}}
    result = wc.solve(case_from_dict(d), fields="last")
    p = result.fields[-1]["pressure"]
    edge = np.concatenate([p[0], p[-1], p[:, 0], p[:, -1]])
    assert result.converged and (edge > 0).any() and result.states[-1]["contact_patches"] >= 1
    # with adhesion, its tension at the edge is the map's own: no warning of a tail cut by the domain
    import warnings

    from warpcontact.records.guards import AdhesionAtEdgeWarning

    d["adhesion"] = {"law": "exponential", "w": 0.05, "rho": 1e-9}
    with warnings.catch_warnings(record=True) as seen:
        warnings.simplefilter("always")
        adhesive = wc.solve(case_from_dict(d), fields="last")
    assert adhesive.converged and (-adhesive.fields[-1]["adhesive_pressure"][0]).max() > 0
    assert not [w for w in seen if issubclass(w.category, AdhesionAtEdgeWarning)]


@pytest.mark.slow
def test_a_rough_surface_against_tamaas():
    """validation/tamaas_rough.py at n = 64: every state's contact area and largest pressure the
    same as Tamaas's non-periodic DC-FFT solve at the same mean pressure (both codes put a uniform
    pressure on each cell), the pressure fields within 1e-6 of their rms (both solve to 1e-10 or
    finer; measured 2e-10)."""
    pytest.importorskip("tamaas", reason="Tamaas is not installed (pip install tamaas)")
    import importlib.util

    spec = importlib.util.spec_from_file_location("tamaas_rough", Path(__file__).resolve().parents[1] / "validation" /
                                                  "tamaas_rough.py")
    study = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(study)
    import json
    import tempfile

    out = Path(tempfile.mkdtemp())
    study.main(["--n", "64", "--steps", "4", "--out", str(out)])
    rows = json.loads((out / "result.json").read_text())
    assert len(rows) >= 3 and all(r["converged"] for r in rows)
    for r in rows:
        assert r["area"] == r["area_tamaas"] and r["pressure_rms_difference"] < 1e-6, r
        assert r["max_pressure"] == pytest.approx(r["max_pressure_tamaas"], rel=1e-6)
