"""FFTW (through pyFFTW) against scipy.fft on the CPU, for the pruned DC-FFT transform pair of the
scipy backend (rows of the N data rows, columns in place, and back), copies included.

The first measurement behind the fftw backend (warpcontact/fft/fftw_backend.py), kept as it was
run: estimated and measured plans made here by hand. The backend's own pair, with its planning,
against scipy's: bench/fftw_planning.py.
    pip install pyfftw && N=512 python bench/fftw_pair.py
"""
import os
import time

import numpy as np
import pyfftw
import scipy.fft as sfft

n = int(os.environ.get("N", 512)); w = 2
x = np.random.rand(n, n)
s = np.zeros((2*n, n+1), complex)
def best(f, r=10):
    f(); b = 1e9
    for _ in range(r):
        t = time.perf_counter(); f(); b = min(b, time.perf_counter() - t)
    return b * 1e3
def scipy_pair():
    s[:n] = sfft.rfft(x, n=2*n, axis=1, workers=w); s[n:] = 0
    out = sfft.fft(s, axis=0, workers=w, overwrite_x=True)
    cols = sfft.ifft(out, axis=0, workers=w, overwrite_x=True)[:n]
    return sfft.irfft(cols, n=2*n, axis=1, workers=w)[:, :n]
print("scipy pair", best(scipy_pair))
# pyfftw plans: rows r2c (n, 2n) -> (n, n+1); columns c2c in place on (2n, n+1); inverse
pyfftw.config.NUM_THREADS = w
rows = pyfftw.empty_aligned((n, 2*n), 'float64'); rows[:] = 0
spec = pyfftw.empty_aligned((2*n, n+1), 'complex128')
rowsout = pyfftw.empty_aligned((n, 2*n), 'float64')
for flags in (('FFTW_ESTIMATE',), ('FFTW_MEASURE',)):
    t0 = time.perf_counter()
    f_rows = pyfftw.FFTW(rows, spec[:n], axes=(1,), direction='FFTW_FORWARD', flags=flags, threads=w)
    f_cols = pyfftw.FFTW(spec, spec, axes=(0,), direction='FFTW_FORWARD', flags=flags, threads=w)
    i_cols = pyfftw.FFTW(spec, spec, axes=(0,), direction='FFTW_BACKWARD', flags=flags, threads=w, normalise_idft=False)
    half = pyfftw.empty_aligned((n, n+1), 'complex128')
    i_rows = pyfftw.FFTW(half, rowsout, axes=(1,), direction='FFTW_BACKWARD', flags=flags, threads=w, normalise_idft=False)
    plan_s = time.perf_counter() - t0
    def fftw_pair():
        rows[:, :n] = x
        f_rows(); spec[n:] = 0
        f_cols()
        i_cols()
        half[:] = spec[:n]
        i_rows()
        return rowsout[:, :n] / (4*n*n)
    print(flags, "plan s", round(plan_s, 2), "fftw pair", best(fftw_pair))
    a, b = scipy_pair(), fftw_pair()
    print("max diff", np.abs(a-b).max()/np.abs(a).max())
