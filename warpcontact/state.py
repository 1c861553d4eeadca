"""The fields of one solved (or to-be-solved) state of a contact."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


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
    Scalars: ``approach`` (delta_x, delta_y, delta_z) [m] and ``info`` (:class:`SolveInfo`).
    """

    FIELDS = (
        "pressure", "shear_x", "shear_y", "gap", "disp_z", "disp_x", "disp_y", "slip_x", "slip_y",
        "adhesive_pressure", "adhesive_shear_x", "adhesive_shear_y",
    )
    TRACTIONS = ("pressure", "shear_x", "shear_y", "adhesive_pressure", "adhesive_shear_x", "adhesive_shear_y")

    def __init__(self, model):
        import warp as wp

        self.model = model
        for name in self.FIELDS:
            setattr(self, name, model.field())
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


def host_si(field, scale: float) -> np.ndarray:
    """The Warp array ``field`` times ``scale`` as a float64 numpy array on the host: the device
    copy plus one pass (a CUDA array's ``numpy()`` is a fresh host copy, scaled in place when it
    is float64; a CPU array's is a view of the field, scaled into a new array). The same values
    as ``field.numpy().astype(np.float64) * scale`` without its second host array."""
    values = field.numpy()
    if field.device.is_cuda and values.dtype == np.float64:
        values *= scale
        return values
    return np.multiply(values, scale, dtype=np.float64)
