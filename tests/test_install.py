"""The package installs with its kernels as ``warpcontact.kernels``."""

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def test_kernels_import_from_the_installed_package():
    """``import warpcontact.kernels`` finds the kernels/ folder that the install maps in."""
    import warp as wp

    import warpcontact.kernels
    from warpcontact.kernels import normal, spectral, tangential

    assert Path(warpcontact.kernels.__file__).parent.name == "kernels"
    assert isinstance(normal.normal_update, wp.Kernel) and isinstance(spectral.spectral_coupled, wp.Kernel)
    assert isinstance(tangential.tangential_update, wp.Kernel)


def test_status_codes_agree():
    from warpcontact.kernels import tangential as tk
    from warpcontact.records.results import STICK

    assert STICK == tk.STICK == 1 and tk.SLIP == 2 and tk.OUT == 0


@pytest.mark.skipif(not (ROOT / "pyproject.toml").exists(), reason="needs the source tree")
def test_pip_install_into_a_folder(tmp_path):
    """``pip install .`` (not editable) lays out warpcontact/ with kernels/ and every subpackage inside it."""
    target = tmp_path / "site"
    r = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--quiet", "--target", str(target), str(ROOT)],
        capture_output=True, text=True, timeout=600,
    )
    assert r.returncode == 0, r.stderr[-2000:]
    assert (target / "warpcontact" / "kernels" / "normal.py").exists()
    for init in sorted((ROOT / "warpcontact").rglob("__init__.py")):  # every subpackage, plots/ included
        package = init.parent.relative_to(ROOT)
        assert (target / package / "__init__.py").exists(), f"{package} is not installed: list it in pyproject.toml"
    code = "import warpcontact.kernels.normal as k, sys; print(k.__file__)"
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path,
                       env={"PYTHONPATH": str(target), "PATH": "/usr/bin:/bin"}, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
    assert r.stdout.strip().startswith(str(target))


def test_api_functions_stay_functions():
    """Calling the API twice works: no submodule of the same name shadows a function."""
    import warpcontact as wc

    for name in ("solve", "path", "gross_slip", "pull_off", "load_case", "case_from_dict"):
        assert callable(getattr(wc, name)), name
    import warpcontact.studies.approach_retract  # noqa: F401
    import warpcontact.studies.slip_search  # noqa: F401

    assert callable(wc.gross_slip) and callable(wc.pull_off)
