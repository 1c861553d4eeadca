"""Warp kernels of warpcontact: ``@wp.kernel`` and ``@wp.func`` code only.

Installed as ``warpcontact.kernels``. Every kernel is generic over the float type and has its
float32 and float64 overloads registered where it is defined, so each module compiles once per
device. Arrays come first, scalars after them, outputs last; no kernel allocates.

Modules:
    spectral: products of traction spectra with the influence spectra (DC-FFT).
    reduce: block reductions used by the solver kernels.
    normal: Polonsky-Keer projected conjugate gradients for the contact pressure.
    tangential: bounded conjugate gradients for the shear traction (disk bound |q| <= q_max).
    laws: shear limits (Coulomb, Tabor + von Mises) and adhesion laws.
"""
