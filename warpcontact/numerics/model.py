"""The contact model: static data shared by every state and solver of one problem."""

from __future__ import annotations

from collections import OrderedDict

import numpy as np
import warp as wp

from warpcontact.kernels import geometry

from .device import dtype_name, numpy_dtype, resolve_device, resolve_dtype
from ..physics.geometry import Grid, Sphere
from .launch import LaunchCache, ReductionLaunch
from ..physics.materials import MaterialPair
from .operator import ElasticOperator
from .resources import check_index_limit


#: window models kept per grid (``ContactModel.window_model``): the normal and the tangential
#: solves' current windows, and one more
WINDOW_MODELS = 3


class ContactModel:
    """Materials, sphere, grid, device, float type and the elastic operator of one problem.

    Internally every field is in scaled units: tractions / ``traction_scale`` (E*), lengths /
    ``length_scale`` (the cell size dx). States convert to SI when asked.

    Args:
        pair: sphere and flat materials.
        sphere: body 1's shape over the flat (``Sphere``: any profile, height maps included).
        grid: the surface grid.
        device: "cpu", "cuda" or "cuda:N".
        dtype: "float64" or "float32".
        fft: FFT backend name ("auto" picks the fastest available on the device).
        influence: where the influence coefficients are computed, "auto", "host" or "device"
            (``ElasticOperator``; "auto": on the device on CUDA, numpy on the CPU).
    """

    def __init__(self, pair: MaterialPair, sphere: Sphere, grid: Grid, device="cpu", dtype="float64", fft="auto",
                 influence="auto"):
        self.pair, self.sphere, self.grid = pair, sphere, grid
        self.device = resolve_device(device)
        self.dtype = resolve_dtype(dtype)
        check_index_limit(grid.n, self.dtype, fft)  # before anything is allocated
        self.np_dtype = numpy_dtype(self.dtype)
        self.length_scale = grid.dx
        self.traction_scale = pair.E_star
        self.n_cells = grid.n * grid.n
        self.reduction = ReductionLaunch.for_cells(self.n_cells, self.device)
        #: launches recorded once and replayed when they repeat (see warpcontact.numerics.launch)
        self.launches = LaunchCache(self.device)
        with wp.ScopedDevice(self.device):
            if self.device.is_cuda and sphere.hertzian:  # on the device (n = 8192: about 1 s of numpy on the host)
                sphere.check_domain(grid)
                self.initial_gap = self.field()
                wp.launch(geometry.sphere_gap, dim=grid.shape,
                          inputs=[grid.n, wp.float64(sphere.radius / grid.dx), int(sphere.profile == "paraboloid")],
                          outputs=[self.initial_gap])
            else:  # the other profiles and height maps: numpy on the host, then copied
                self.initial_gap = self.field(sphere.initial_gap(grid) / self.length_scale)
            self.operator = ElasticOperator(pair, grid, self.device, self.dtype, fft, influence)
        self._windows: OrderedDict = OrderedDict()  # cells -> the model of a window of that side

    def on_grid(self, grid: Grid, dtype: str | None = None) -> "ContactModel":
        """A model of the same materials, sphere, device, FFT backend and float type (or
        ``dtype``) on ``grid`` (the nested start's coarse grid, a tangential solve's window): the
        gap made again on it (a height map resampled to its cells)."""
        return ContactModel(self.pair, self.sphere, grid, device=self.device, dtype=dtype or self.dtype_name,
                            fft=self.fft_name)

    def window_model(self, cells: int) -> "ContactModel | None":
        """The model of a square window of ``cells`` per side of this grid (the same cells: the
        same influence coefficients, padded to 2 cells), which the normal and tangential solves
        on a window share (``SolverSettings.window``); kept per size (``WINDOW_MODELS``, the
        least recently used let go). None on CUDA where a friction problem of that size would not
        fit in the free memory (the solves then run on the whole grid). Its ``initial_gap`` is
        the sphere's centred on the window: a solve that reads it writes the crop of this grid's
        first."""
        cells = int(cells)
        model = self._windows.get(cells)
        if model is None:
            if self.device.is_cuda:
                from . import resources

                need = resources.breakdown(cells, self.dtype_name, "cuda", True, self.fft_name, states=0)["total"]
                if need > resources.memory_limit(self.device)[0]:
                    return None
            model = self._windows[cells] = self.on_grid(Grid(cells, cells * self.grid.dx))
            model.operator.transient()  # its size follows the contact: plans not worth measuring
            while len(self._windows) > WINDOW_MODELS:
                self._windows.popitem(last=False)
        self._windows.move_to_end(cells)
        return model

    @property
    def dtype_name(self) -> str:
        return dtype_name(self.dtype)

    @property
    def fft_name(self) -> str:
        return self.operator.fft.name

    def launch(self, kernel, dim, inputs, outputs=()):
        """``wp.launch`` on the model's device, recorded the first time and replayed after."""
        self.launches.launch(kernel, dim, inputs, outputs)

    def launch_cells(self, kernel, inputs, outputs=()):
        """An elementwise kernel of one thread per cell; on the CPU, with its fields marked
        `warpcontact.numerics.launch.Rows`, split by rows over the CPU's threads."""
        self.launches.launch_cells(kernel, self.grid.shape, inputs, outputs)

    def launch_reduce(self, kernel, inputs, outputs):
        """A reducing kernel (kernels/reduce.py) over all cells: ``inputs``, then the launch shape's
        argument (its ``Cells``: which cells each thread visits), then ``outputs``. On the CPU, with its fields marked
        `warpcontact.numerics.launch.Rows` and its sums `warpcontact.numerics.launch.Sums`, split by
        rows over the CPU's threads (``LaunchCache.split``)."""
        self.launches.launch_reduce(kernel, self.reduction, self.n_cells, inputs, outputs, rows=self.grid.shape)

    def scalar(self, value: float):
        """``value`` as a Warp scalar of the model's float type (for kernel arguments)."""
        return self.dtype(value)

    def field(self, values=None) -> wp.array:
        """A (n, n) field on the model's device: zeros, or a copy of ``values`` (scaled units)."""
        if values is None:
            return wp.zeros(self.grid.shape, dtype=self.dtype, device=self.device)
        return wp.array(np.asarray(values, dtype=self.np_dtype), dtype=self.dtype, device=self.device)

    def scalars(self, count: int) -> wp.array:
        return wp.zeros(count, dtype=self.dtype, device=self.device)
