"""Summaries of solved states and files that are written whole or not at all."""

from __future__ import annotations

import json
import math
import os
import tempfile
from pathlib import Path

import numpy as np

from warpcontact.kernels.tangential import STICK


def state_summary(state) -> dict:
    """Forces, areas and convergence of one solved state, SI units, JSON-ready.

    force: force the sphere exerts on the flat [N] (z: compressive positive; x, y: the
    tangential load carried by the contact). Areas in m^2, lengths in m, pressures in Pa.
    """
    m = state.model
    f = state.to_numpy_si()
    dA = m.grid.cell_area
    contact = f["pressure"] > 0
    stick = state.status.numpy() == STICK
    X, Y = m.grid.mesh()
    area = float(contact.sum() * dA)
    stick_area = float(stick.sum() * dA)
    info = state.info
    out = {
        "delta": {"x": state.approach[0], "y": state.approach[1], "z": state.approach[2]},
        "force": {
            "x": float(f["shear_x"].sum() * dA),
            "y": float(f["shear_y"].sum() * dA),
            "z": float(f["pressure"].sum() * dA),
        },
        "contact_area": area,
        "contact_radius": math.sqrt(area / math.pi),
        "max_pressure": float(f["pressure"].max()),
        "stick_area": stick_area,
        "stick_centroid": (
            {"x": float(X[stick].mean()), "y": float(Y[stick].mean())} if stick.any() else None
        ),
        "converged": bool(info.converged) if info else False,
        "iterations": int(info.iterations) if info else 0,
        "outer_iterations": int(info.outer_iterations) if info else 0,
        "residual": float(info.residual) if info else math.nan,
    }
    return out


def state_fields(state) -> dict:
    """Fields of a state for an NPZ file: SI float64 arrays and the masks, numpy only."""
    f = state.to_numpy_si()
    status = state.status.numpy()
    f["contact_mask"] = f["pressure"] > 0
    f["stick_mask"] = status == STICK
    f["status"] = status.astype(np.int8)
    return f


def atomic_write_bytes(path, data: bytes):
    """Write ``data`` to ``path`` through a temporary file and a rename: readers see all or nothing."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=path.name + ".", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


def atomic_write_json(path, obj):
    atomic_write_bytes(path, (json.dumps(obj, indent=2, allow_nan=True) + "\n").encode())


def atomic_write_npz(path, arrays: dict):
    import io

    buf = io.BytesIO()
    np.savez_compressed(buf, **arrays)
    atomic_write_bytes(path, buf.getvalue())
