"""Self-affine rough surfaces: synthesis by Fourier filtering and the statistics of a height map.

The power spectral density (PSD) and the quantities below follow Jacobs, Junge & Pastewka,
"Quantitative characterization of surface topography using spectral analysis", Surf. Topogr.:
Metrol. Prop. 5 (2017) 013001: a self-affine surface of Hurst exponent H has the isotropic PSD
C(q) ~ q^(-2 - 2H) between the wavevectors of its long- and short-wavelength cutoffs,
q_r = 2 pi / lambda_r and q_s = 2 pi / lambda_s, constant below q_r (the roll-off) and zero
above q_s. The synthesis filters white Gaussian noise by sqrt(C(q)) (their section 4; Persson et
al. 2005), which makes a periodic surface with Gaussian heights and random phases.

Conventions: heights in m, shape (n, n), the first axis along x (as case files read height maps:
docs/surfaces.md), square pixels of side ``pixel_size`` [m]. The PSD of an n x n map of side
L = n pixel_size is C(q_k) = pixel_size^2 / n^2 |H_k|^2 [m^4], H the discrete Fourier transform
of the heights, so that <h^2> = (1 / L^2) sum_k C(q_k) (Parseval).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import InputError


def _wavevectors(n: int, pixel_size: float) -> np.ndarray:
    """|q| [1/m] of each entry of an n x n discrete Fourier transform, shape (n, n)."""
    q = 2.0 * np.pi * np.fft.fftfreq(n, d=pixel_size)
    return np.hypot(q[:, None], q[None, :])


def _positive(key: str, v) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or not v > 0:
        raise InputError(key, f"must be a positive finite number, got {v!r}")
    return float(v)


def rough_surface(n: int, size: float, hurst: float, *, rms_height: float | None = None,
                  rms_slope: float | None = None, short_cutoff: float | None = None,
                  long_cutoff: float | None = None, seed: int = 0) -> np.ndarray:
    """A synthetic self-affine, periodic rough surface: heights [m], shape (n, n), mean 0.

    Args:
        n: pixels per side (>= 8).
        size: side of the square map [m]; the pixel is size / n.
        hurst: Hurst exponent H, 0 < H < 1 (the PSD falls as q^(-2 - 2H)).
        rms_height: the surface's rms height [m]; or
        rms_slope: its rms slope [-] (forward differences on the pixels, as
            ``surface_statistics`` measures it); exactly one of the two. The realisation
            is scaled so that the asked value holds exactly; the other follows the spectrum.
        short_cutoff: lambda_s [m], the shortest wavelength (default: 2 pixels, none cut).
        long_cutoff: lambda_r [m], the roll-off wavelength (default: size, no roll-off).
        seed: seed of the random phases (numpy's default_rng): the same seed, the same surface.

    Raises:
        InputError: naming the argument (``hurst``, ``rms_height``, ...) that is out of range.
    """
    if isinstance(n, bool) or not isinstance(n, (int, np.integer)) or n < 8:
        raise InputError("n", f"must be an integer of at least 8, got {n!r}")
    size = _positive("size", size)
    if isinstance(hurst, bool) or not isinstance(hurst, (int, float)) or not 0.0 < hurst < 1.0:
        raise InputError("hurst", f"must lie in (0, 1), got {hurst!r}")
    if (rms_height is None) == (rms_slope is None):
        raise InputError("rms_height", "give exactly one of rms_height [m] and rms_slope [-]")
    target = _positive("rms_height", rms_height) if rms_slope is None else _positive("rms_slope", rms_slope)
    pixel = size / n
    lam_s = 2.0 * pixel if short_cutoff is None else _positive("short_cutoff", short_cutoff)
    lam_r = size if long_cutoff is None else _positive("long_cutoff", long_cutoff)
    if lam_s < 2.0 * pixel * (1.0 - 1e-12):
        raise InputError("short_cutoff", f"must be at least two pixels ({2.0 * pixel:.4g} m), got {lam_s:.4g} m")
    if not lam_r > lam_s:
        raise InputError("long_cutoff", f"must exceed short_cutoff ({lam_s:.4g} m), got {lam_r:.4g} m")
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise InputError("seed", f"must be a non-negative integer, got {seed!r}")
    q = _wavevectors(n, pixel)
    q_r, q_s = 2.0 * np.pi / lam_r, 2.0 * np.pi / lam_s
    psd = np.where(q < q_r, q_r, q) ** (-2.0 - 2.0 * hurst)
    psd[(q > q_s * (1.0 + 1e-12)) | (q == 0.0)] = 0.0
    noise = np.random.default_rng(int(seed)).standard_normal((n, n))
    h = np.fft.ifft2(np.fft.fft2(noise) * np.sqrt(psd)).real
    h -= h.mean()
    stats = surface_statistics(h, pixel, fit=False)
    return h * (target / (stats["rms_height"] if rms_slope is None else stats["rms_slope"]))


def power_spectrum(heights: np.ndarray, pixel_size: float, bins: int = 32) -> tuple[np.ndarray, np.ndarray]:
    """The radially averaged PSD of a square map: (q [1/m], C(q) [m^4]) at ``bins`` logarithmic
    bins between 2 pi / L and the Nyquist wavevector pi / pixel_size (empty bins left out). The
    map is taken as periodic (no window: a measured, non-periodic map's edges add a q^-4 tail)."""
    h = np.asarray(heights, dtype=np.float64)
    n = h.shape[0]
    c = (pixel_size / n) ** 2 * np.abs(np.fft.fft2(h - h.mean())) ** 2
    q = _wavevectors(n, pixel_size)
    edges = np.geomspace(2.0 * np.pi / (n * pixel_size), np.pi / pixel_size, bins + 1)
    which = np.digitize(q.ravel(), edges) - 1
    inside = (which >= 0) & (which < bins)
    count = np.bincount(which[inside], minlength=bins)
    qsum = np.bincount(which[inside], weights=q.ravel()[inside], minlength=bins)
    csum = np.bincount(which[inside], weights=c.ravel()[inside], minlength=bins)
    full = count > 0
    return qsum[full] / count[full], csum[full] / count[full]


def fitted_hurst(q: np.ndarray, c: np.ndarray, q_min: float, q_max: float) -> float:
    """H from a least-squares line through log C against log q for q_min <= q <= q_max: the
    slope is -2 - 2H. NaN where fewer than three points lie in that band."""
    band = (q >= q_min) & (q <= q_max) & (c > 0.0)
    if np.count_nonzero(band) < 3:
        return math.nan
    slope = np.polyfit(np.log(q[band]), np.log(c[band]), 1)[0]
    return -(slope + 2.0) / 2.0


def surface_statistics(heights, pixel_size: float, *, fit: bool = True, q_min: float | None = None,
                       q_max: float | None = None) -> dict:
    """The statistics of a height map (Jacobs, Junge & Pastewka 2017, section 2):

    - rms_height [m]: sqrt(<(h - <h>)^2>);
    - rms_slope [-]: sqrt(<|grad h|^2>), the gradient by forward differences on the pixels;
    - rms_curvature [1/m]: the rms of the mean curvature (laplacian of h) / 2, the five-point
      laplacian on the inner pixels;
    - min, max [m] (of the heights as given), size [m] along x and y, pixel_size [m], shape;
    - with ``fit``, hurst [-]: fitted to the radially averaged PSD (``power_spectrum``)
      between q_min and q_max [1/m] (default: 4 times the smallest wavevector 2 pi / L and half
      the Nyquist wavevector pi / pixel_size: wavelengths from L / 4 down to 4 pixels; on
      128 x 128 synthetic maps the fit scatters by 0.04 about the input H), and
      those bounds (a square map only; None otherwise).

    ``heights``: shape (nx, ny), the first axis along x, in m.
    """
    h = np.asarray(heights, dtype=np.float64)
    p = _positive("pixel_size", pixel_size)
    if h.ndim != 2 or min(h.shape) < 3:
        raise InputError("heights", f"must be a 2-D map of at least 3 x 3 heights, got shape {h.shape}")
    if not np.isfinite(h).all():
        raise InputError("heights", "holds values that are not finite numbers (NaN or inf)")
    gx, gy = np.diff(h, axis=0) / p, np.diff(h, axis=1) / p
    slope2 = np.mean(gx[:, :-1] ** 2 + gy[:-1, :] ** 2)
    lap = (h[2:, 1:-1] + h[:-2, 1:-1] + h[1:-1, 2:] + h[1:-1, :-2] - 4.0 * h[1:-1, 1:-1]) / (p * p)
    out = {"rms_height": float(np.std(h)), "rms_slope": float(math.sqrt(slope2)),
           "rms_curvature": float(np.sqrt(np.mean((0.5 * lap) ** 2))), "min": float(h.min()), "max": float(h.max()),
           "shape": list(h.shape), "pixel_size": p, "size": [h.shape[0] * p, h.shape[1] * p]}
    if fit:
        out.update(hurst=None, fit_q_min=None, fit_q_max=None)
        if h.shape[0] == h.shape[1]:
            n = h.shape[0]
            lo = 4.0 * 2.0 * np.pi / (n * p) if q_min is None else q_min
            hi = 0.5 * np.pi / p if q_max is None else q_max
            hurst = fitted_hurst(*power_spectrum(h, p), lo, hi)
            out.update(hurst=None if math.isnan(hurst) else float(hurst), fit_q_min=float(lo), fit_q_max=float(hi))
    return out


__all__ = ["fitted_hurst", "power_spectrum", "rough_surface", "surface_statistics"]
