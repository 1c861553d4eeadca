"""The fields of one solved (or to-be-solved) state of a contact.

Also what the solver checks on a state during its step: whether the contact fits in the domain
(:func:`check_contact_fits`, on the edge cells gathered on the device by :func:`domain_edge`).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError
from ..physics.geometry import profile_note


@dataclass
class SolveInfo:
    """Convergence record of one solve.

    Attributes:
        converged: the residual fell under the tolerance.
        iterations: iterations of the innermost solver(s) used, summed.
        residual: final relative residual (see the solver's docstring for its definition).
        history: relative residual per iteration (normal solver), for plots.
    """

    converged: bool
    iterations: int
    residual: float
    outer_iterations: int = 0
    history: list = field(default_factory=list)


#: a state's fields up to this many bytes together are one allocation (``ContactState``)
ONE_BLOCK_BYTES = 64 << 20


class ContactState:
    """Fields of one state on the model's device, in the model's scaled units.

    Attributes (Warp arrays of shape (n, n), row = y, column = x):
        pressure: elastic contact pressure p_c / E* (>= 0).
        shear_x, shear_y: shear traction the sphere exerts on the flat, / E*.
        gap: h / dx, the normal gap after deformation.
        disp_z: u_z / dx, the normal relative displacement (into the bodies, summed).
        disp_x, disp_y: u_t / dx, tangential displacement of the flat relative to the sphere.
        slip_x, slip_y: accumulated slip of the sphere relative to the flat since the start of the
            path, / dx (s = delta - u_t).
        adhesive_pressure: p_adh / E* (<= 0, tension), on cells out of contact.
        adhesive_shear_x, adhesive_shear_y: adhesive shear on the flat / E*, out of contact.
    Total tractions: pressure + adhesive_pressure, shear + adhesive_shear.
    Scalars: ``approach`` (delta_x, delta_y, delta_z) [m] and ``info`` (`SolveInfo`).
    """

    FIELDS = (
        "pressure", "shear_x", "shear_y", "gap", "disp_z", "disp_x", "disp_y", "slip_x", "slip_y",
        "adhesive_pressure", "adhesive_shear_x", "adhesive_shear_y",
    )
    TRACTIONS = ("pressure", "shear_x", "shear_y", "adhesive_pressure", "adhesive_shear_x", "adhesive_shear_y")

    def __init__(self, model):
        import warp as wp

        self.model = model
        layers = len(self.FIELDS)
        if layers * model.n_cells * np.dtype(model.np_dtype).itemsize <= ONE_BLOCK_BYTES:
            # one allocation for every field (a batch makes a state for each of hundreds of small
            # cases): each field a view of its layer, its own contiguous (n, n) array
            block = wp.zeros((layers, *model.grid.shape), dtype=model.dtype, device=model.device)
            fields = [block[k] for k in range(layers)]
        else:  # a large grid's fields each on its own: no single block of many GB to find
            fields = [model.field() for _ in range(layers)]
        for name, values in zip(self.FIELDS, fields):
            setattr(self, name, values)
        #: cell status, int32 (n, n): 0 out of contact, 1 stick, 2 slip (kernels/tangential.py)
        self.status = wp.zeros(model.grid.shape, dtype=wp.int32, device=model.device)
        self.approach = (0.0, 0.0, 0.0)
        self.info: SolveInfo | None = None

    def copy_from(self, other: "ContactState"):
        import warp as wp

        for name in self.FIELDS + ("status",):
            wp.copy(getattr(self, name), getattr(other, name))
        self.approach = other.approach
        self.info = other.info

    def to_numpy_si(self) -> dict:
        """Every field as a float64 numpy array in SI units (Pa for tractions, m for lengths)."""
        m = self.model
        out = {}
        for name in self.FIELDS:
            scale = m.traction_scale if name in self.TRACTIONS else m.length_scale
            out[name] = host_si(getattr(self, name), scale)
        return out


#: the page-locked host arrays ``host_si`` copies CUDA fields through, by (device, shape, float
#: type): made on first use and kept (a path's states have fields of one shape), at most
#: ``PINNED_STAGES_KEPT`` (a sweep over grid sizes lets the older ones go)
_PINNED_STAGES: dict = {}
PINNED_STAGES_KEPT = 2


def _pinned_stage(field):
    """The page-locked host array ``host_si`` stages ``field`` in, or None where the host refuses
    page-locked memory (then the plain copy)."""
    import warp as wp

    key = (str(field.device), field.shape, field.dtype)
    stage = _PINNED_STAGES.get(key)
    if stage is None:
        while len(_PINNED_STAGES) >= PINNED_STAGES_KEPT:
            del _PINNED_STAGES[next(iter(_PINNED_STAGES))]  # the oldest
        try:
            stage = _PINNED_STAGES[key] = wp.empty(field.shape, dtype=field.dtype, device="cpu", pinned=True)
        except (RuntimeError, MemoryError):
            return None
    return stage


def host_si(field, scale: float) -> np.ndarray:
    """The Warp array ``field`` times ``scale`` as a new float64 numpy array on the host. A
    contiguous CUDA field is copied into a page-locked host array kept for its shape and type
    (``_PINNED_STAGES``) and scaled from there into the new array: at n = 1024 on an H200 a CUDA
    array's own ``numpy()`` (a fresh pageable host copy) moved 0.9 GB/s, and a path's fields were
    the solve command's largest part after the solve. A CPU field's is a view of it, scaled into
    a new array."""
    import warp as wp

    if field.device.is_cuda and field.is_contiguous:
        stage = _pinned_stage(field)
        if stage is not None:
            wp.copy(stage, field)
            wp.synchronize_stream(wp.get_stream(field.device))  # the copy to page-locked memory is asynchronous
            return np.multiply(stage.numpy(), scale, dtype=np.float64)
    values = field.numpy()
    if field.device.is_cuda and values.dtype == np.float64:
        values *= scale
        return values
    return np.multiply(values, scale, dtype=np.float64)


def domain_edge(field) -> np.ndarray:
    """The cells of the 2-D Warp array ``field`` on the domain's edge, as numpy's
    ``concatenate([f[0], f[-1], f[:, 0], f[:, -1]])`` (the corners twice), in the field's units
    and float type: gathered on its device, one transfer of 2 (rows + columns) values."""
    import warp as wp

    from warpcontact.kernels import summary as sk

    rows, columns = field.shape
    edge = wp.empty(2 * (rows + columns), dtype=field.dtype, device=field.device)
    wp.launch(sk.domain_edge, dim=edge.shape, inputs=[field], outputs=[edge], device=field.device)
    return edge.numpy()


#: share of the domain's edge cells in contact after the first turn of a step above which the step
#: stops there (``check_contact_fits``). The first turn solves loosely against the last state's
#: shear, and its contact can pass the converged one's: at n = 64 (the AFM tip of tests/test_first_hour.py with friction
#: on a domain of side 2.03 Hertz radii) 40 of the 4 x 64 edge cells against none at the step's end.
#: A disc over half the edge reaches 1.12 half-sides, 0.06 n cells past the edge (2 at n = 32); one
#: that merely touches the edge is judged at the step's end. On that case (sides 2.2-3.0 nm; n = 32
#: and 64 without adhesion, n = 32 with it) every path stops at the same state as with the step-end
#: check alone.
EDGE_SHARE_AT_FIRST_TURN = 0.5


def check_contact_fits(state, approach=None, edge_share: float = 0.0, edge_contact: float | None = None):
    """InputError (key ``grid.size``) if contact cells touch the edge of the domain: the domain is
    too small for the load, and the DC-FFT solution would miss the contact beyond it. Made after
    each step, and after the first turn of a step that turns (``ContactSolver``) with
    ``edge_share`` = EDGE_SHARE_AT_FIRST_TURN, so that a contact far past the edge stops the run
    at once rather than after the turn limit. ``approach``: (delta_x, delta_y, delta_z) [m] of
    the step, named in the message (default: ``state.approach``); ``edge_share``: the share of the
    edge's cells in contact above which it raises [-] (0: any cell). A body given as a height map
    (``profile = "height_map"``) is the map over the domain, with nothing beyond it: its contact
    may reach the edge. ``edge_contact``: the count of the edge's cells in contact where it is made
    already (a batch's summaries, ``kernels/summary.py``'s S_EDGE_CONTACT), with ``edge_share`` 0."""
    if state.model.sphere.fills_domain:
        return  # the body is its map, cut by nothing: the non-periodic contact of the map as given
    if edge_contact is not None:
        touches = edge_contact > 0
    else:
        touches = np.mean(domain_edge(state.pressure) > 0) > edge_share  # the edge cells alone leave the device
    if touches:
        g = state.model.grid
        dx, dy, dz = state.approach if approach is None else approach
        raise InputError(
            "grid.size",
            f"the contact reaches the edge of the {g.size:.4g} m domain at delta = ({dx:.4g}, {dy:.4g}, {dz:.4g}) m; "
            f"use at least {1.5 * g.size:.4g} m{profile_note(1.5 * g.size, state.model.sphere)} (and more cells to "
            f"keep the resolution)",
        )
