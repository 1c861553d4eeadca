"""The coupled elastic operator: DC-FFT convolution of (p, q_x, q_y) to (u_z, u_x, u_y).

Works in the model's scaled units: tractions divided by E*, lengths by the cell size dx, so that
the influence coefficients are of order one in float32 and float64 alike.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
import warp as wp

from warpcontact.kernels import fft as fft_kernels
from warpcontact.kernels import spectral

from ..errors import InputError
from ..fft import make_fft, make_periodic_fft
from .launch import FirstRow, LaunchCache, ReductionLaunch, Rows, Sums
from ..physics.influence import (KERNELS, SPECTRUM_PARTS, chan_circulant, device_coefficients,
                                 influence_coefficients)

#: where the influence coefficients are computed (``ElasticOperator``'s ``influence``)
INFLUENCE_PATHS = ("auto", "host", "device")


#: the kernels whose circulant inverses precondition the solves (K_zz, and K_tt's block), in the
#: spectral kernels' order (``kernels/spectral.py``: ZZ, XX, YY, XY)
PRECONDITIONER_KERNELS = KERNELS[:4]


class InverseTransforms(NamedTuple):
    """Where the preconditioners run (``ElasticOperator.inverse_transforms``): an FFT backend (of
    the operator's padded grid, or of the grid itself where ``fft.periodic``), two of its spectral
    buffers (x and y) and the circulants' spectra (at least K_zz, K_xx, K_yy, K_xy, in the spectral
    kernels' order), all in the backend's float type; and what the spectral sums over them take:
    the spectrum's entries, their reduction's launch, the Parseval scale in the operator's float
    type, and K_zz's mirrored read (``ElasticOperator.normal_product``; 0: none)."""

    fft: object
    buffers: list
    influence: wp.array
    entries: int
    reduction: ReductionLaunch
    energy_scale: object
    mirror: int


class ElasticOperator:
    """Maps tractions to relative surface displacements through the influence spectra.

    Args:
        pair: the material pair.
        grid: the surface grid.
        device, dtype: where and in which float type the fields live.
        fft: FFT backend name ("auto", "scipy", "cupy", "warp").
        influence: where the influence coefficients are computed: "host" (numpy,
            ``influence_coefficients``), "device" (Warp kernels on the operator's device,
            ``device_coefficients``) or "auto": the device on CUDA, the host on the CPU (numpy on
            the CPU's threads is faster there than Warp's one-thread CPU kernels: docs/performance.md,
            "Set-up").

    The spectra of the six influence kernels are computed once and kept on the device, each as
    its one non-zero part, real or imaginary (by the FFT backend: float64 on the host, then cast;
    cuFFT on the device with the cupy backend); three spectral buffers are allocated once. Beside
    them, where the backend has transforms of the grid itself (``make_periodic_fft``), the spectra
    of T. Chan's optimal circulants of K_zz, K_xx, K_yy and K_xy on the (n, n) grid
    (``chan_circulant``), which the preconditioners may run on (``inverse_transforms``). The
    coefficients are float64 whatever ``dtype``; on the device path the cupy backend transforms
    them where they are (cast on the device as the host path casts on the host), the others get
    a host copy (the warp backend on CUDA, whose spectra are made on the host).
    """

    def __init__(self, pair, grid, device, dtype, fft: str = "auto", influence: str = "auto"):
        self.pair, self.grid = pair, grid
        self.device, self.dtype = device, dtype
        self.shape = grid.shape
        self.fft = make_fft(fft, grid.n, grid.n, device, dtype)
        self.launches = LaunchCache(self.fft.device)
        # K_zz is even: on CUDA the energy product reads its spectrum up to the middle of the full
        # axis and mirrors past it, half of K_zz's bytes (``spectral_normal_energy``'s ``mirror``)
        mirror = self.fft.spectral_shape[1 - self.fft.half_axis] if self.fft.device.is_cuda else 0
        self.coupled = pair.D != 0.0
        scale = pair.E_star / grid.dx  # scaled displacement per scaled traction
        if influence not in INFLUENCE_PATHS:
            raise InputError("influence", f"unknown path {influence!r}; choose one of {', '.join(INFLUENCE_PATHS)}")
        if influence == "auto":
            influence = "device" if self.fft.device.is_cuda else "host"
        #: where the influence coefficients were computed: "host" or "device"
        self.influence_path = influence
        if influence == "host":
            coeffs = influence_coefficients(pair, grid.n, grid.n, grid.dx, grid.dy)
            self._self_coefficients = {k: float(coeffs[k][0, 0] * scale) for k in KERNELS}
            # (np.linalg.norm: a dot product of the flattened view, no temporary array of the grid)
            self._column_norms = {k: float(np.linalg.norm(coeffs[k]) * abs(scale)) for k in KERNELS}

            def scaled():  # each coefficient array scaled in place and let go once transformed
                for k in KERNELS:
                    a = coeffs.pop(k)
                    a *= scale
                    periodic_spectrum(k, a)
                    yield a
        else:
            self._self_coefficients, self._column_norms = {}, {}
            on_device = getattr(self.fft, "takes_device_coefficients", False)

            def scaled():  # each array made scaled on the device (float64) and let go once transformed
                for k, a in device_coefficients(pair, grid.n, grid.n, grid.dx, grid.dy, self.fft.device, scale=scale):
                    self._self_coefficients[k] = float(a.flatten()[:1].numpy()[0])  # offset (0, 0)
                    self._column_norms[k] = float(np.sqrt(wp.utils.array_inner(a, a)))
                    periodic_spectrum(k, a)
                    yield a if on_device else a.numpy()
                    del a  # (one array at a time: let go before the next is made)

        # the preconditioners' circulants on the grid itself, each transformed as its kernel's
        # coefficients pass (``periodic_spectrum``): none where the backend has no such transforms
        periodic = make_periodic_fft(self.fft.name, grid.n, grid.n, self.fft.device, dtype)
        if periodic is not None:
            periodic_influence = periodic.alloc_influence(len(PRECONDITIONER_KERNELS))
            periodic_buffers = [wp.zeros(periodic.spectral_shape, dtype=periodic.complex_dtype, device=periodic.device)
                                for _ in range(2)]

        def periodic_spectrum(kernel: str, coefficients):
            """The circulant's spectrum of a preconditioner's kernel from its (scaled) coefficients."""
            if periodic is None or kernel not in PRECONDITIONER_KERNELS:
                return
            circulant = chan_circulant(coefficients)
            if isinstance(circulant, wp.array) and not getattr(periodic, "takes_device_coefficients", False):
                circulant = circulant.numpy()
            k = PRECONDITIONER_KERNELS.index(kernel)
            periodic.influence_spectra([circulant], [SPECTRUM_PARTS[kernel]], periodic_influence[k:k + 1],
                                       periodic_buffers[0])

        # three buffers, one array each: a stacked (3, ...) array's first stride (one spectrum)
        # would pass Warp's 32-bit strides at n = 8192 in float64 (resources.index_limit)
        self._buf = [wp.zeros(self.fft.spectral_shape, dtype=self.fft.complex_dtype, device=self.fft.device)
                     for _ in range(3)]
        #: the six influence spectra, each real or imaginary: only that part (SPECTRUM_PARTS)
        self.influence = self.fft.alloc_influence(len(KERNELS))
        self.fft.influence_spectra(scaled(), [SPECTRUM_PARTS[k] for k in KERNELS], self.influence, self._buf[0])
        self._padded_inverse = self._inverse(self.fft, self._buf[1:3], self.influence, mirror)
        self._periodic_inverse = None if periodic is None else self._inverse(periodic, periodic_buffers,
                                                                             periodic_influence)
        self._inverse32 = {}  # periodic -> inverse_transforms(float32=True, periodic), made when first asked

    def self_coefficient(self, kernel: str) -> float:
        """Displacement of a cell under its own unit traction, scaled units (kernel in KERNELS)."""
        return self._self_coefficients[kernel]

    def column_norm(self, kernel: str) -> float:
        """2-norm of the displacements one cell's unit traction causes over the padded grid, scaled
        units: ||K e_j||_2 <= this for every cell j, so ||K c||_2 <= this * ||c||_1."""
        return self._column_norms[kernel]

    def spectral_product(self, kernel, spectra, transforms: "InverseTransforms | None" = None):
        """Launch the product ``kernel`` (kernels/spectral.py) on ``spectra``, in place: one entry
        per thread on CUDA, one row per thread on the CPU (``LaunchCache.launch_rows``), the rows
        split over the CPU's threads. ``transforms``: the spectra are of these, with their
        influence spectra (:meth:`inverse_transforms`; default: the operator's own)."""
        fft, influence = (self.fft, self.influence) if transforms is None else (transforms.fft, transforms.influence)
        self.launches.launch_rows(kernel, fft.spectral_shape, [Rows(influence, axis=1), *(Rows(s) for s in spectra)])

    def normal(self, pressure: wp.array2d, displacement: wp.array2d):
        """displacement <- K_zz pressure (no coupling)."""
        self.fft.forward(pressure, self._buf[0])
        self.spectral_product(spectral.spectral_normal, self._buf[:1])
        self.fft.inverse(self._buf[0], displacement)

    def normal_product(self, spectrum: wp.array2d, energy: wp.array | None = None, slot: int = 0,
                       inverse: bool = False, transforms: "InverseTransforms | None" = None):
        """The spectral product of K_zz on ``spectrum``, in place; with ``energy``, also
        ``energy[slot] += (K_zz t) . t`` for the field t whose spectrum it is, summed in Fourier
        space (Parseval; ``spectral.spectral_normal_energy``: no pass over the grid of its own;
        in ``energy``'s float type). ``inverse``: the product of the circulant inverse 1 / K_zz
        instead, with its sum t . (K_zz^-1 t) (``energy`` required), the normal solver's
        preconditioner. ``transforms``: the spectrum is of these (``inverse_transforms``; default:
        the operator's own)."""
        if energy is None:
            if inverse:
                raise ValueError("normal_product: the inverse product is launched with its sum (pass energy)")
            self.spectral_product(spectral.spectral_normal, [spectrum])
            return
        t = transforms or self._padded_inverse
        self.launches.launch_reduce(
            spectral.spectral_normal_energy, t.reduction, t.entries,
            [Rows(t.influence, axis=1), Rows(spectrum), t.fft.half_axis, t.fft.half_length, t.energy_scale,
             int(inverse), int(slot), FirstRow(), t.mirror],
            [Sums(energy)], rows=t.fft.spectral_shape)

    def normal_padded(self, energy: wp.array | None = None, slot: int = 0, inverse: bool = False,
                      transforms: "InverseTransforms | None" = None):
        """K_zz applied to the field a kernel wrote into the corner of ``fft.padded_input``; the
        result, times ``fft.output_scale``, in the corner of ``fft.padded_output`` (for solver
        kernels that pad and crop as part of their own passes). ``energy``, ``slot``,
        ``inverse``: as :meth:`normal_product`. ``transforms``: run on these
        (:meth:`inverse_transforms`; ``fft`` above is theirs; default: the operator's own)."""
        fft, spectrum = (self.fft, self._buf[0]) if transforms is None else (transforms.fft, transforms.buffers[0])
        fft.transform_input(spectrum)
        self.normal_product(spectrum, energy, slot, inverse, transforms)
        fft.transform_to_output(spectrum)

    def tangential(self, shear_x, shear_y, disp_x, disp_y, transforms: "InverseTransforms | None" = None):
        """(disp_x, disp_y) <- K_tt (shear_x, shear_y) (no coupling). ``transforms``: on these
        padded transforms and their spectra (:meth:`response_transforms`: float32 beside float64
        fields), else the operator's own."""
        if transforms is None:
            self.fft.forward(shear_x, self._buf[1])
            self.fft.forward(shear_y, self._buf[2])
            self.spectral_product(spectral.spectral_tangential, self._buf[1:])
            self.fft.inverse(self._buf[1], disp_x)
            self.fft.inverse(self._buf[2], disp_y)
            return
        # through the padded buffers: the padding and cropping kernels round between the float types
        fft, buffers = transforms.fft, transforms.buffers
        rows = self.shape
        for field, spectrum in zip((shear_x, shear_y), buffers):
            self.launches.launch_rows(fft_kernels.pad_field, rows, [Rows(field)], [Rows(fft.padded_input)])
            fft.transform_input(spectrum)
        self.spectral_product(spectral.spectral_tangential, buffers, transforms)
        for spectrum, field in zip(buffers, (disp_x, disp_y)):
            fft.transform_to_output(spectrum)
            self.launches.launch_rows(fft_kernels.crop_field, rows, [Rows(fft.padded_output), fft.output_scale],
                                      [Rows(field)])

    def coupled_apply(self, pressure, shear_x, shear_y, disp_z, disp_x, disp_y):
        """(disp_z, disp_x, disp_y) <- the full 3x3 operator applied to (pressure, shear_x, shear_y)."""
        for src, buf in zip((pressure, shear_x, shear_y), self._buf):
            self.fft.forward(src, buf)
        self.spectral_product(spectral.spectral_coupled, self._buf)
        for buf, dst in zip(self._buf, (disp_z, disp_x, disp_y)):
            self.fft.inverse(buf, dst)

    def coupled_shear(self, pressure, shear_x, shear_y, disp_z, disp_x, disp_y):
        """(disp_x, disp_y) <- K_tp p + K_tt q and disp_z <- K_zt q: the tangential displacement
        of both tractions and the shear's normal one, from one forward transform of each (three
        forward transforms and three inverse, where ``cross_tangential``, ``tangential`` and
        ``cross_normal`` make ten); disp_z None: the tangential displacement alone (two inverse
        transforms)."""
        for src, buf in zip((pressure, shear_x, shear_y), self._buf):
            self.fft.forward(src, buf)
        self.spectral_product(spectral.spectral_coupled_shear, self._buf)
        for buf, dst in zip(self._buf, (disp_z, disp_x, disp_y)):
            if dst is not None:
                self.fft.inverse(buf, dst)

    def cross_normal(self, shear_x, shear_y, disp_z):
        """disp_z <- K_zt q: the shear's normal displacement (coupling only; two forward
        transforms and one inverse)."""
        self.fft.forward(shear_x, self._buf[1])
        self.fft.forward(shear_y, self._buf[2])
        self.spectral_product(spectral.spectral_cross_normal, self._buf)
        self.fft.inverse(self._buf[0], disp_z)

    def cross_tangential(self, pressure, disp_x, disp_y):
        """(disp_x, disp_y) <- K_tp p: the pressure's tangential displacement (coupling only; one
        forward transform and two inverse)."""
        self.fft.forward(pressure, self._buf[0])
        self.spectral_product(spectral.spectral_cross_tangential, self._buf)
        self.fft.inverse(self._buf[1], disp_x)
        self.fft.inverse(self._buf[2], disp_y)

    # --- the circulant inverse of the tangential block: the tangential solver's preconditioner ---

    def _inverse(self, fft, buffers: list, influence: wp.array, mirror: int = 0) -> InverseTransforms:
        """``InverseTransforms`` of a backend, its buffers and spectra, with its spectral sums' launch."""
        sy, sx = fft.spectral_shape
        return InverseTransforms(fft, buffers, influence, sy * sx, ReductionLaunch.for_cells(sy * sx, fft.device),
                                 self.dtype(float(fft.energy_scale)), mirror)

    @property
    def has_periodic_preconditioner(self) -> bool:
        """Whether the preconditioners may run on the grid itself (``inverse_transforms``)."""
        return self._periodic_inverse is not None

    def transient(self):
        """This operator's grid serves a few solves (a window): its backends' plans made cheaply
        (``FFTBackend.transient``)."""
        for t in (self._padded_inverse, self._periodic_inverse, *self._inverse32.values()):
            if t is not None:
                t.fft.transient()

    def inverse_transforms(self, float32: bool = False, periodic: bool = False) -> "InverseTransforms":
        """The FFT backend, two spectral buffers and the circulants' spectra that the
        preconditioners (the circulant inverses) run on:

        - ``periodic``: on the grid itself, T. Chan's circulants (transforms of n^2 entries, not
          4 n^2; ``SolverSettings.preconditioner_grid``), where the backend has such transforms
          (``has_periodic_preconditioner``), else as without it;
        - else the operator's own padded grid and influence spectra (the DC-FFT's circulant);
        - ``float32`` in a float64 operator: float32 ones of the same grid
          (``SolverSettings.preconditioner_float32``), made when first asked: a float32 backend of
          the same kind, two float32 spectral buffers and the four spectra rounded to float32."""
        periodic = bool(periodic and self._periodic_inverse is not None)
        base = self._periodic_inverse if periodic else self._padded_inverse
        if not float32 or self.dtype == wp.float32:
            return base
        if periodic not in self._inverse32:
            n, device = self.grid.n, base.fft.device
            fft = (make_periodic_fft if periodic else make_fft)(base.fft.name, n, n, device, wp.float32)
            if base.fft.is_transient:
                fft.transient()
            kept = len(PRECONDITIONER_KERNELS)
            influence = wp.empty((kept, *fft.spectral_shape), dtype=wp.float32, device=device)
            wp.launch(spectral.float32_copy, dim=influence.shape, inputs=[base.influence[:kept]], outputs=[influence],
                      device=device)
            buffers = [wp.zeros(fft.spectral_shape, dtype=fft.complex_dtype, device=device) for _ in range(2)]
            self._inverse32[periodic] = self._inverse(fft, buffers, influence, base.mirror)
        return self._inverse32[periodic]

    def response_transforms(self) -> "InverseTransforms":
        """The float32 transforms of the padded grid with the influence spectra of K_zz and K_tt
        rounded to float32 (those of ``inverse_transforms(float32=True)``, made when first asked;
        the operator's own in a float32 operator): where a float64 solve makes the response of
        its conjugate direction in float32 (``SolverSettings.response_float32``)."""
        return self.inverse_transforms(float32=True, periodic=False)

    def tangential_column_norm(self) -> float:
        """Bound on the 2-norm of the displacements one cell's unit shear (of any direction)
        causes over the padded grid, scaled units: the Frobenius norm of the cell's two columns
        of K_tt, sqrt(|K_xx|^2 + 2 |K_xy|^2 + |K_yy|^2); so ||K_tt c||_2 <= this * sum_j |c_j|."""
        c = self._column_norms
        return float(np.sqrt(c["xx"] ** 2 + 2.0 * c["xy"] ** 2 + c["yy"] ** 2))

    def tangential_inverse_product(self, energy: wp.array, slot: int, eigen_floor: float,
                                   inverse: "InverseTransforms | None" = None):
        """The circulant inverse of K_tt (``spectral.spectral_tangential_inverse_energy``, its
        eigenvalues floored at ``eigen_floor``, scaled) on the spectra in the buffers of
        ``inverse`` (default: the operator's own shear buffers ``_buf[1]``, ``_buf[2]``), in
        place, and ``energy[slot] += g . M g`` for the fields g whose spectra they are
        (Parseval; summed in ``energy``'s float type)."""
        inverse = inverse or self.inverse_transforms()
        fft = inverse.fft
        self.launches.launch_reduce(
            spectral.spectral_tangential_inverse_energy, inverse.reduction, inverse.entries,
            [Rows(inverse.influence, axis=1), *(Rows(b) for b in inverse.buffers), fft.half_axis, fft.half_length,
             inverse.energy_scale, fft.dtype(eigen_floor), int(slot), FirstRow()],
            [Sums(energy)], rows=fft.spectral_shape)

    def tangential_inverse_padded(self, fill_x, fill_y, use_x, use_y, energy: wp.array, slot: int,
                                  eigen_floor: float, inverse: "InverseTransforms | None" = None):
        """M g for solver kernels that pad and crop as part of their own passes: ``fill_x()`` and
        ``fill_y()`` each write one component of g into the corner of ``padded_input`` of
        ``inverse.fft`` (each is transformed before the next is written); M g's components come
        out in the corner of its ``padded_output`` (times its ``output_scale``), x while
        ``use_x()`` runs, then y while ``use_y()`` runs. ``energy[slot] += g . M g``. Four
        transforms and the spectral product (:meth:`tangential_inverse_product`); ``inverse``:
        :meth:`inverse_transforms` (default: the operator's own)."""
        inverse = inverse or self.inverse_transforms()
        fft, (spectrum_x, spectrum_y) = inverse.fft, inverse.buffers
        fill_x()
        fft.transform_input(spectrum_x)
        fill_y()
        fft.transform_input(spectrum_y)
        self.tangential_inverse_product(energy, slot, eigen_floor, inverse)
        fft.transform_to_output(spectrum_x)
        use_x()
        fft.transform_to_output(spectrum_y)
        use_y()

    def tangential_inverse(self, grad_x, grad_y, out_x, out_y, energy: wp.array, slot: int, eigen_floor: float):
        """(out_x, out_y) <- M (grad_x, grad_y) on (n, n) fields, M the circulant inverse of K_tt
        (:meth:`tangential_inverse_product`), and ``energy[slot] += g . M g``."""
        self.fft.forward(grad_x, self._buf[1])
        self.fft.forward(grad_y, self._buf[2])
        self.tangential_inverse_product(energy, slot, eigen_floor)
        self.fft.inverse(self._buf[1], out_x)
        self.fft.inverse(self._buf[2], out_y)
