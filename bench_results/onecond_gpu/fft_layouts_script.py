"""Scratch run of 2026-11-23 (kept as the record of layouts.log): cuFFT layouts of the padded DC-FFT pair. It ran against a working tree whose pruned forward transformed the columns out of place (never committed); the in-place variant it times became the layout of commit 6c11832. bench/iteration_parts.py times the layouts of the current code."""
import ctypes, math, sys, time
import warp as wp
from warpcontact.fft import cupy_backend as cb
from warpcontact.fft.cupy_backend import CupyFFT, _check, _FORWARD, _INVERSE

wp.config.quiet = True
wp.init()
dev = wp.get_device("cuda:0")


def timed(fn, reps=20):
    fn()
    with wp.ScopedCapture(device=dev, force_module_load=False) as cap:
        for _ in range(reps):
            fn()
    best = math.inf
    for _ in range(3):
        wp.synchronize_device(dev); t0 = time.perf_counter(); wp.capture_launch(cap.graph); wp.synchronize_device(dev)
        best = min(best, time.perf_counter() - t0)
    return 1e3 * best / reps


for dtype in (wp.float64, wp.float32):
    for n in (1024, 2048, 4096):
        two = CupyFFT(n, n, dev, dtype, pruned=False)
        pr = CupyFFT(n, n, dev, dtype, pruned=True)
        spec = pr.alloc_spectra(1)[0]
        lib = pr._lib
        # in-place variant: rows into spectrum top half, zero the bottom half, columns in place
        def inplace_fwd():
            with wp.ScopedDevice(dev):
                _check(pr._real_to_complex(pr._row_forward, pr._rows_in.ptr, spec.ptr), "row")
                spec[n:].zero_()
                _check(pr._complex_to_complex(pr._column_plan, spec.ptr, spec.ptr, _FORWARD), "col")
        res = {
            "2d fwd": timed(lambda: two._transforms_forward(spec)),
            "2d inv": timed(lambda: two._transforms_inverse(spec)),
            "pruned fwd (out of place)": timed(lambda: pr._transforms_forward(spec)),
            "pruned fwd (in place+memset)": timed(inplace_fwd),
            "pruned inv": timed(lambda: pr._transforms_inverse(spec)),
            "row D2Z only": timed(lambda: pr._real_to_complex(pr._row_forward, pr._rows_in.ptr, pr._columns_in.ptr)),
            "col fwd only (oop)": timed(lambda: pr._complex_to_complex(pr._column_plan, pr._columns_in.ptr, spec.ptr, _FORWARD)),
            "col inv only (in place)": timed(lambda: pr._complex_to_complex(pr._column_plan, spec.ptr, spec.ptr, _INVERSE)),
            "memset half": timed(lambda: spec[n:].zero_()),
        }
        print(f"n {n} {dtype.__name__}: " + ", ".join(f"{k} {v:.3f}" for k, v in res.items()), flush=True)
        del two, pr, spec
