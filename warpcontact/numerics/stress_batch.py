"""The von Mises maxima of many cases at many depths at once: the yield check of a batch of solved
states (``yielding.batch_yield_checks``).

``SubsurfaceStress.von_mises_maxima`` evaluates one case depth after depth: at each depth the
basis spectra one by one, then each body's stress spectra, six inverse transforms, its von Mises
field and its maximum, read on the host; on a GPU a small grid spends that time launching. Here a
*plane* is one depth below one case's surface, and every step runs once for all the planes of a
chunk: ``kernels/stress.py``'s plane kernels (the 14 weighted basis quadrants of every plane; the
stress spectra of every body at every plane, each case's materials and tractions; the largest
von Mises stress along every row), the transforms batched by the FFT library (``fft.batch``:
scipy.fft on the CPU, CuPy's cuFFT on CUDA), and one read of the row maxima a chunk. The method
and its numbers are ``SubsurfaceStress``': the same basis integrals and combination
(``body_stress_spectra``), so a plane's maxima equal its evaluation alone to round-off.
"""

from __future__ import annotations

import numpy as np

from .stress import BASIS, BODIES, body_coefficients, used_bases

#: bytes a chunk of planes may take on a device (its stacks and the library's work arrays): a
#: plane must fit in this much for a check to be made by planes (``yielding.checks_by_planes``)
CHUNK_BYTES = 1 << 30
#: on CUDA a chunk takes up to an eighth of the device's free memory, between CHUNK_BYTES and
#: this: each chunk costs the host a few ms of launches and a read, so a batch's hundreds of
#: planes go in few chunks where the memory is there
MAX_CHUNK_BYTES = 8 << 30


#: the cuFFT plans the yield checks' library keeps (one per count of grids a transform takes: a
#: stack's, a chunk's): a sweep's checks repeat a few counts, so its later checks make none
CHECK_PLANS = 32
_LIBRARIES: dict = {}  # (device alias, stream) -> the yield checks' BatchLibrary there


def check_library(device):
    """The batched FFT library the yield checks on ``device`` share (their plans kept across
    checks, ``CHECK_PLANS`` at most)."""
    from ..fft.batch import BatchLibrary

    import warp as wp

    key = (device.alias, wp.get_stream(device).cuda_stream if device.is_cuda else None)  # its plans run on it
    library = _LIBRARIES.get(key)
    if library is None:
        library = _LIBRARIES[key] = BatchLibrary(device, max_plans=CHECK_PLANS)
    return library


class PlaneStress:
    """The von Mises maxima of each body at planes (case, depth) of cases on one n x n grid.

    Args:
        n: cells per side.
        device: a Warp device.
        dtype: ``wp.float32`` or ``wp.float64``.
    """

    def __init__(self, n: int, device, dtype):
        import warp as wp

        from .device import numpy_dtype

        self.n, self.dtype = int(n), dtype
        self.device = wp.get_device(device)
        self.library = check_library(self.device)
        self.np_dtype = numpy_dtype(dtype)
        self.vector = wp.vec2d if dtype == wp.float64 else wp.vec2f
        self.rows, self.cols = 2 * self.n, self.n + 1
        #: planes evaluated together (``chunk_budget``)
        self.chunk = max(1, self.chunk_budget(self.device) // self.plane_bytes(n, dtype))

    @staticmethod
    def plane_bytes(n: int, dtype) -> int:
        """Bytes one plane takes on the device at n cells per side: at most 14 basis corners,
        quadrants and spectra, 6 stress spectra and fields a body, and the library's intermediate
        arrays (about as much again)."""
        from .device import numpy_dtype

        real = np.dtype(numpy_dtype(dtype)).itemsize
        spectrum = 2 * n * (n + 1) * 2 * real
        field = n * n * real
        return 2 * (len(BASIS) * (8 * (n + 1) ** 2 + field + spectrum) + len(BODIES) * 6 * (field + spectrum))

    @staticmethod
    def chunk_bytes() -> int:
        """Bytes a chunk of planes may take at least (``CHUNK_BYTES``)."""
        return CHUNK_BYTES

    @staticmethod
    def chunk_budget(device) -> int:
        """Bytes a chunk of planes may take on ``device``: ``CHUNK_BYTES``, on CUDA up to an eighth
        of its free memory (at most ``MAX_CHUNK_BYTES``)."""
        if not device.is_cuda:
            return CHUNK_BYTES
        return max(CHUNK_BYTES, min(MAX_CHUNK_BYTES, int(device.free_memory) // 8))

    def _forward(self, fields, spectra):
        """spectra <- the transforms of (k, n, n) ``fields`` zero-padded to (2 n, 2 n) (numpy's
        rfft2 layout, the half axis last)."""
        import warp as wp

        from warpcontact.kernels import spectral_batch as sbk

        k, n = fields.shape[0], self.n
        padded = wp.zeros((k, 2 * n, 2 * n), dtype=self.dtype)
        wp.launch(sbk.batch_pad, dim=(k, n * n), inputs=[fields.reshape((k, n * n)), n], outputs=[padded])
        self.library.forward(padded, spectra.reshape((k, self.rows, self.cols)))

    def _inverse(self, spectra, fields):
        """(k, n, n) ``fields`` <- the inverse transforms of ``spectra`` (overwritten), cropped
        (unnormalised: the weights of ``plane_stress_spectra`` hold the 1 / (4 n^2))."""
        import warp as wp

        from warpcontact.kernels import spectral_batch as sbk

        k, n = fields.shape[0], self.n
        padded = wp.empty((k, 2 * n, 2 * n), dtype=self.dtype)
        self.library.inverse(spectra.reshape((k, self.rows, self.cols)), padded)
        wp.launch(sbk.batch_crop, dim=(k, n * n), inputs=[padded, n], outputs=[fields.reshape((k, n * n))])

    def maxima(self, pairs: list, stack, loaded: list, planes: list) -> np.ndarray:
        """The largest von Mises stress of each body at each plane: (len(planes), 2, 3) array of
        value [Pa], row and column of the cell (body order ``BODIES``; 0 for a rigid body).

        ``pairs[c]``: case c's materials; ``stack``: the cases' total tractions, a (3 cases, n, n)
        Warp array on this device, case c's (p, q_x, q_y) scaled by its E* (a ``ContactState``'s
        units) in layers 3 c .. 3 c + 2; ``loaded[c]``: which of the three are loaded (an unloaded
        one's layer is zero and takes no terms); ``planes``: (case, depth in cells) each."""
        import warp as wp

        out = np.zeros((len(planes), len(BODIES), 3))
        if not planes:
            return out
        try:
            with self.library.on_device(), wp.ScopedDevice(self.device):
                traction_spectra = wp.empty((stack.shape[0] * self.rows, self.cols), dtype=self.vector)
                self._forward(stack, traction_spectra)
                for first in range(0, len(planes), self.chunk):
                    part = planes[first:first + self.chunk]
                    out[first:first + len(part)] = self._chunk(pairs, loaded, traction_spectra, part)
        finally:
            self.library.release(work=True)
        return out

    def _chunk(self, pairs, loaded, traction_spectra, planes) -> np.ndarray:
        """``maxima`` of one chunk of planes, from the cases' traction spectra."""
        import warp as wp

        from warpcontact.kernels import stress as ks

        n, rows, cols, bodies = self.n, self.rows, self.cols, len(BODIES)
        p_count, q_count = len(planes), len(planes) * bodies
        scale = 1.0 / (4 * n * n)  # the inverse transforms' (``_inverse``)
        # each body's arguments of ``body_stress_spectra`` at its plane (zero for a rigid body: a
        # zero stress)
        coefficients = np.zeros((q_count, 5))
        for p, (c, z) in enumerate(planes):
            for b, name in enumerate(BODIES):
                if name in pairs[c].elastic:
                    coefficients[p * bodies + b] = body_coefficients(pairs[c].elastic[name].nu, name == "sphere", z,
                                                                     loaded[c], scale)
        # the bases any case's loads use (8 of the 14 for pressures alone), each in a slot of its own
        used = np.array(used_bases(np.any([loaded[c] for c in {c for c, _ in planes}], axis=0)), dtype=np.int64)
        slots = np.full(len(BASIS), -1, dtype=np.int32)
        slots[used] = np.arange(len(used))
        # the basis spectra depend on the depth alone: once per distinct depth of the chunk (the
        # cases of a sweep over delta_x share their contact radius, so their depths)
        distinct, plane_depth = np.unique(np.array([z for _, z in planes], dtype=np.float64), return_inverse=True)
        depths = wp.array(distinct, dtype=wp.float64)
        plane_case = wp.array(np.array([c for c, _ in planes], dtype=np.int32), dtype=int)
        k = len(distinct) * len(used)
        corners = wp.empty((k, n + 1, n + 1), dtype=wp.float64)
        wp.launch(ks.plane_basis_corners, dim=corners.shape,
                  inputs=[depths, wp.array(used.astype(np.int32), dtype=int)], outputs=[corners])
        quadrants = wp.empty((k, n, n), dtype=self.dtype)
        wp.launch(ks.plane_basis_quadrants, dim=quadrants.shape, inputs=[corners], outputs=[quadrants])
        del corners
        basis_spectra = wp.empty((k * rows, cols), dtype=self.vector)
        self._forward(quadrants, basis_spectra)
        del quadrants
        stress_spectra = wp.empty((q_count * 6 * rows, cols), dtype=self.vector)
        wp.launch(ks.plane_stress_spectra, dim=(q_count, rows, cols),
                  inputs=[basis_spectra, traction_spectra, plane_case,
                          wp.array(plane_depth.astype(np.int32).ravel(), dtype=int), bodies, len(used),
                          wp.array(slots, dtype=int), wp.array(coefficients.astype(self.np_dtype), dtype=self.dtype),
                          1, rows],
                  outputs=[stress_spectra])
        del basis_spectra
        stress = wp.empty((q_count * 6, n, n), dtype=self.dtype)
        self._inverse(stress_spectra, stress)
        del stress_spectra
        values = wp.empty((q_count, n), dtype=self.dtype)
        cols_at = wp.empty((q_count, n), dtype=int)
        wp.launch(ks.plane_von_mises_rows, dim=(q_count, n), inputs=[stress], outputs=[values, cols_at])
        values, cols_at = values.numpy(), cols_at.numpy()
        row = np.argmax(values, axis=1)
        best = values[np.arange(q_count), row].astype(np.float64)
        col = cols_at[np.arange(q_count), row]
        e_star = np.repeat([pairs[c].E_star for c, _ in planes], bodies)
        return np.stack([best * e_star, row, col], axis=1).reshape(p_count, bodies, 3)
