"""Summaries of solved states, as dicts of SI numbers and as fields; the atomic writes (warpcontact.files)
named here too."""

from __future__ import annotations

import math
import weakref

import numpy as np

# the atomic writes live in warpcontact.files (the shared role: FFTW's wisdom is written there too);
# their names here are the ones the studies and the command line have always used
from ..files import (
    NPZ_COMPRESS_BELOW_BYTES,
    atomic_write_bytes,
    atomic_write_json,
    atomic_write_npz,
    free_bytes,
    output_error,
)
from warpcontact.kernels.tangential import STICK

from ..numerics.state import domain_edge, host_si  # noqa: F401  (domain_edge: named here too)


def adhesive_mask(fields: dict, adhesion) -> np.ndarray:
    """A_adh: cells out of elastic contact whose gap is within the law's range (MODEL.md 6)."""
    if adhesion is None:
        return np.zeros_like(fields["pressure"], dtype=bool)
    return (fields["pressure"] <= 0) & (fields["gap"] <= adhesion.range)


#: per model: the device array the summary kernel adds to, and its starting values (kept, so that a
#: summary allocates nothing and copies nothing from the host)
_SUMMARY_BUFFERS = weakref.WeakKeyDictionary()


def summary_buffers(device, rows: int | None = None) -> tuple:
    """The device array a summary kernel adds to and its starting values (0 in every slot, -inf in
    S_MAX_PRESSURE and S_MAX_TENSION), float64: N_SUMMARY slots, or (``rows``, N_SUMMARY) for one
    row a case of a batch (``kernels/summary.py``'s ``batch_summary_sums``)."""
    import warp as wp

    from warpcontact.kernels import summary as sk

    start = np.zeros(sk.N_SUMMARY if rows is None else (rows, sk.N_SUMMARY))
    start[..., sk.S_MAX_PRESSURE] = start[..., sk.S_MAX_TENSION] = -np.inf
    start = wp.array(start, dtype=wp.float64, device=device)
    return wp.zeros_like(start), start


def summary_sums(state, adhesion=None) -> np.ndarray:
    """The sums of ``kernels/summary.py`` for ``state`` (its slots S_*), float64 on the host: one
    pass over the fields on the model's device (one launch; on the CPU split by rows over its
    threads) and one transfer of the small array."""
    import warp as wp

    from warpcontact.kernels import summary as sk

    from ..numerics.launch import FirstRow, Rows, Sums

    m = state.model
    buffers = _SUMMARY_BUFFERS.get(m)
    if buffers is None:
        buffers = _SUMMARY_BUFFERS[m] = summary_buffers(m.device)
    sums, start = buffers
    wp.copy(sums, start)
    fields = [Rows(getattr(state, name).flatten()) for name in (
        "pressure", "adhesive_pressure", "shear_x", "adhesive_shear_x", "shear_y", "adhesive_shear_y", "gap", "status")]
    rows, columns = m.grid.shape
    reach = float(adhesion.range) if adhesion is not None else 0.0
    m.launch_reduce(sk.summary_sums, [*fields, columns, rows, FirstRow(), wp.float64(m.length_scale), wp.float64(reach),
                                      int(adhesion is not None)],
                    [Sums(sums, maxima=(int(sk.S_MAX_PRESSURE), int(sk.S_MAX_TENSION)))])
    return np.array(sums.numpy(), dtype=np.float64)  # a copy: on the CPU numpy() is a view of the buffer


def state_summary(state, adhesion=None, sums=None) -> dict:
    """Forces, areas and convergence of one solved state, SI units, JSON-ready.

    force: total force the sphere exerts on the flat [N] (z: compressive positive, adhesive
    part included; x, y: the tangential load carried by the interface); force_elastic: the
    contact tractions alone. Areas in m^2 (contact A_c, stick A_st, adhesive A_adh), lengths in
    m, pressures in Pa. ``mean_gap`` [m]: the gap averaged over the domain, the mean separation of
    the deformed surfaces (zero in contact). For shapes other than the sphere and the paraboloid (a
    punch, a cone, height maps: ``Sphere.hertzian`` False) also ``contact_patches``: the number
    of connected regions of contact cells (neighbours across an edge; :func:`contact_patches`),
    from the pressure read on the host.

    Reduced on the model's device (:func:`summary_sums`, or ``sums``: the state's row of a batch's
    sums, ``kernels/summary.py``'s ``batch_summary_sums``): no field reaches the host. The forces
    agree with float64 sums of the SI fields on the host to the rounding of a float64 sum, about
    n_cells x 1.1e-16 of the sum of the magnitudes, for float32 states too (their values are
    summed in float64); the areas, the maximum pressure and the stick centroid's cell offsets
    are exact (``tests/test_summary_device.py``).
    """
    from warpcontact.kernels import summary as sk

    m = state.model
    s = summary_sums(state, adhesion) if sums is None else sums
    dA = m.grid.cell_area
    E = m.traction_scale
    area = float(s[sk.S_CONTACT_CELLS] * dA)
    stick_cells = s[sk.S_STICK_CELLS]
    info = state.info
    out = {
        "delta": {"x": state.approach[0], "y": state.approach[1], "z": state.approach[2]},
        "force": {
            "x": float(s[sk.S_FORCE_X] * E * dA),
            "y": float(s[sk.S_FORCE_Y] * E * dA),
            "z": float(s[sk.S_FORCE_Z] * E * dA),
        },
        "force_elastic": {
            "x": float(s[sk.S_ELASTIC_X] * E * dA),
            "y": float(s[sk.S_ELASTIC_Y] * E * dA),
            "z": float(s[sk.S_ELASTIC_Z] * E * dA),
        },
        "adhesive_area": float(s[sk.S_ADHESIVE_CELLS] * dA),
        "contact_area": area,
        "contact_radius": math.sqrt(area / math.pi),
        "max_pressure": float(s[sk.S_MAX_PRESSURE] * E),
        "mean_gap": float(s[sk.S_GAP] * m.length_scale / m.n_cells),
        "stick_area": float(stick_cells * dA),
        "stick_centroid": (
            {"x": float(s[sk.S_STICK_X] * m.grid.dx / stick_cells),
             "y": float(s[sk.S_STICK_Y] * m.grid.dy / stick_cells)} if stick_cells > 0 else None
        ),
        "converged": bool(info.converged) if info else False,
        "iterations": int(info.iterations) if info else 0,
        "outer_iterations": int(info.outer_iterations) if info else 0,
        "residual": float(info.residual) if info else math.nan,
    }
    if not m.sphere.hertzian:
        out["contact_patches"] = contact_patches(state.pressure.numpy())
    return out


def contact_patches(pressure: np.ndarray) -> int:
    """The number of patches of a contact: connected regions of cells with p > 0, cells joined
    across an edge (4-connectivity: cells touching at a corner only are apart, as the DC-FFT
    grid resolves nothing between them). ``pressure``: (n, n), any units."""
    from scipy import ndimage

    return int(ndimage.label(np.asarray(pressure) > 0)[1])


def shear_limit_si(state, friction=None) -> np.ndarray:
    """q_max of each cell [Pa], float64 (n, n): the friction law's shear limit at the state's
    contact pressure (what the tangential solve bounds |q| by); zeros for a frictionless contact."""
    if friction is None:
        return np.zeros(state.model.grid.shape, dtype=np.float64)
    m = state.model
    out = m.field()
    friction.shear_limit(m, state.pressure.flatten(), out.flatten())
    return host_si(out, m.traction_scale)


def state_fields(state, adhesion=None, friction=None) -> dict:
    """Fields of a state for an NPZ file: SI float64 arrays and the masks, numpy only;
    ``shear_limit`` [Pa] is the friction law's q_max of each cell (zeros without friction)."""
    f = state.to_numpy_si()
    f["shear_limit"] = shear_limit_si(state, friction)
    status = state.status.numpy()
    f["contact_mask"] = f["pressure"] > 0
    f["adhesive_mask"] = adhesive_mask(f, adhesion)
    f["stick_mask"] = status == STICK
    f["status"] = status.astype(np.int8)
    return f
