"""Synthetic rough surfaces and the statistics of height maps (warpcontact.physics.roughness, the
``warpcontact surface`` command): the asked rms height or slope, the Hurst exponent fitted near the
input, reproducible by seed; statistics of surfaces with known answers; the written map read as a
case's [flat] height_map; mistakes named by their option."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

import warpcontact as wc
from warpcontact.errors import InputError
from warpcontact.physics.roughness import rough_surface, surface_statistics
from warpcontact.records.case import case_from_dict


def test_the_asked_rms_holds_and_the_seed_reproduces():
    """The realisation is scaled to the asked value: rms height, or rms slope, exact to round-off;
    mean 0; the same seed gives the same surface, another seed another."""
    h = rough_surface(64, 64e-9, 0.7, rms_height=2e-9, seed=3)
    assert h.shape == (64, 64) and abs(h.mean()) < 1e-12 * 2e-9
    assert surface_statistics(h, 1e-9)["rms_height"] == pytest.approx(2e-9, rel=1e-12)
    s = rough_surface(64, 64e-9, 0.7, rms_slope=0.1, seed=3)
    assert surface_statistics(s, 1e-9)["rms_slope"] == pytest.approx(0.1, rel=1e-12)
    assert np.array_equal(h, rough_surface(64, 64e-9, 0.7, rms_height=2e-9, seed=3))
    assert not np.allclose(h, rough_surface(64, 64e-9, 0.7, rms_height=2e-9, seed=4), rtol=0, atol=1e-11)
    assert np.allclose(s / np.std(s), h / np.std(h))  # one spectrum, one set of phases: only the scale differs


@pytest.mark.parametrize("hurst", [0.3, 0.8])
def test_the_fitted_hurst_exponent_is_near_the_input(hurst):
    """The PSD's fitted exponent, on 128 x 128 maps (wavelengths L/4 to 4 pixels): the fit of one
    random realisation scatters by about 0.04 (measured over 10 seeds: 0.295 +- 0.039 for 0.3,
    0.794 +- 0.038 for 0.8), so each of 5 seeds within 0.15 (4 standard deviations) and their mean
    within 0.06 (3 standard deviations of a mean of 5)."""
    fits = [surface_statistics(rough_surface(128, 128e-9, hurst, rms_height=1e-9, seed=s), 1e-9)["hurst"]
            for s in range(5)]
    assert all(abs(f - hurst) < 0.15 for f in fits), fits
    assert abs(np.mean(fits) - hurst) < 0.06, fits


def test_statistics_of_surfaces_with_known_answers():
    """A tilted plane: rms slope its tilt, no curvature; a paraboloid r^2 / 2R: mean curvature
    1/R everywhere; min and max as given."""
    p = 1e-9
    x = np.arange(32)[:, None] * p + 0 * np.arange(32)[None, :]
    plane = surface_statistics(0.05 * x, p, fit=False)
    assert plane["rms_slope"] == pytest.approx(0.05) and plane["rms_curvature"] == pytest.approx(0.0, abs=1e-3)
    c = (np.arange(33) - 16) * p
    bowl = (c[:, None] ** 2 + c[None, :] ** 2) / (2 * 1e-6)
    st = surface_statistics(bowl, p)
    assert st["rms_curvature"] == pytest.approx(1e6, rel=1e-9) and st["min"] == 0.0
    assert st["max"] == pytest.approx(2 * (16 * p) ** 2 / 2e-6) and st["shape"] == [33, 33]


@pytest.mark.parametrize("kwargs, key", [
    ({"hurst": 1.2, "rms_height": 1e-9}, "hurst"),
    ({"hurst": 0.5}, "rms_height"),
    ({"hurst": 0.5, "rms_height": 1e-9, "rms_slope": 0.1}, "rms_height"),
    ({"hurst": 0.5, "rms_height": -1e-9}, "rms_height"),
    ({"hurst": 0.5, "rms_slope": math.nan}, "rms_slope"),
    ({"hurst": 0.5, "rms_height": 1e-9, "short_cutoff": 1e-9}, "short_cutoff"),  # one pixel
    ({"hurst": 0.5, "rms_height": 1e-9, "long_cutoff": 3e-9}, "long_cutoff"),  # below the short cutoff
    ({"hurst": 0.5, "rms_height": 1e-9, "seed": -1}, "seed"),
])
def test_mistakes_name_the_argument(kwargs, key):
    with pytest.raises(InputError) as e:
        rough_surface(32, 32e-9, **{"short_cutoff": 4e-9, **kwargs})
    assert e.value.key == key, str(e.value)


def run_cli(*args):
    return subprocess.run([sys.executable, "-m", "warpcontact.cli", "surface", *map(str, args)], capture_output=True,
                          text=True, timeout=300)


def test_the_command_writes_a_map_a_case_reads_and_its_statistics(tmp_path):
    """surface.npy, surface.json and psd.png; the map as a [flat] height_map with surface.json's
    pixel_size and unit; --stats prints the same statistics as surface.json holds."""
    out = tmp_path / "rough"
    r = run_cli("--out", out, "--n", 64, "--size", 64e-9, "--hurst", 0.8, "--rms-height", 1e-9, "--seed", 2)
    assert r.returncode == 0, r.stderr
    meta = json.loads((out / "surface.json").read_text())
    assert meta["pixel_size"] == pytest.approx(1e-9) and meta["height_unit"] == "m"
    assert meta["statistics"]["rms_height"] == pytest.approx(1e-9)
    assert (out / "psd.png").read_bytes()[:4] == b"\x89PNG"
    heights = np.load(out / "surface.npy")
    assert np.array_equal(heights, wc.rough_surface(64, 64e-9, 0.8, rms_height=1e-9, seed=2))
    case = case_from_dict({"sphere": {"radius": 1e-6, "E": 100e9, "nu": 0.3},
                           "flat": {"E": 100e9, "nu": 0.3, "height_map": meta["height_map"],
                                    "pixel_size": meta["pixel_size"], "height_unit": meta["height_unit"]},
                           "grid": {"n": 32, "size": 32e-9}, "load": {"delta_z": 1e-10}}, base=out)
    assert case.sphere.flat_map.heights.shape == (64, 64)
    r = run_cli("--stats", out / "surface.npy", "--pixel-size", 1e-9)
    assert r.returncode == 0, r.stderr
    assert f"rms height     {meta['statistics']['rms_height']:.6g} m" in r.stdout
    assert f"{meta['statistics']['hurst']:.4f}" in r.stdout


@pytest.mark.parametrize("args, option", [
    (["--stats", "missing.npy", "--pixel-size", 1e-9], "--stats"),
    (["--stats", "map.npy"], "--pixel-size"),
    (["--stats", "map.npy", "--pixel-size=-1e-9"], "--pixel-size"),
    (["--stats", "map.npy", "--pixel-size", 1e-9, "--height-unit", "inch"], "--height-unit"),
    (["--out", "o", "--size", 1e-7, "--hurst", 1.5, "--rms-height", 1e-9], "--hurst"),
    (["--out", "o", "--size", 1e-7], "--rms-height"),
    (["--out", "o", "--rms-height", 1e-9], "--size"),
    (["--size", 1e-7, "--rms-height", 1e-9], "--out"),
])
def test_the_command_refuses_in_one_line_with_exit_2(tmp_path, args, option):
    np.save(tmp_path / "map.npy", np.zeros((8, 8)))
    r = subprocess.run([sys.executable, "-m", "warpcontact.cli", "surface", *map(str, args)], capture_output=True,
                       text=True, timeout=300, cwd=tmp_path)
    lines = [ln for ln in r.stderr.strip().splitlines() if not ln.startswith("Warp CUDA warning")]
    assert r.returncode == 2 and len(lines) == 1 and option in lines[0], r.stderr
    assert "Traceback" not in r.stderr
