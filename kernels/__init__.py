"""Warp kernels of warpcontact: ``@wp.kernel`` and ``@wp.func`` code only.

Installed as ``warpcontact.kernels``. The solver kernels are generic over the float type and
have their float32 and float64 overloads registered where they are defined, so each module
compiles once per device; the tile-FFT kernels (``fft``) are built per length and dtype by a
cached factory, since tile sizes are compile-time constants. Arrays come first, scalars after them, outputs last; no kernel allocates.

Modules:
    spectral: products of traction spectra with the influence spectra (DC-FFT).
    reduce: block reductions used by the solver kernels.
    normal: Polonsky-Keer projected conjugate gradients for the contact pressure.
    tangential: bounded conjugate gradients for the shear traction (disk bound |q| <= q_max).
    laws: shear limits (Coulomb, Tabor + von Mises).
    coupling: stick targets, slip accumulation, relative changes between coupling turns.
    grids: transfers between a grid and the grid of half its cells (the nested start of a step),
        and a square window of a grid cut out and put back (the tangential solve on its contact).
    geometry: the sphere's gap before deformation, made on the device.
    influence: the Boussinesq-Cerruti influence coefficients, computed on the device.
    adhesion, adhesive: the traction-separation laws' tractions, and the adhesive normal problem
        as one minimisation.
    fixed_point: Anderson mixing of the turns (one set of coefficients, or each cell's own).
    stress: the subsurface stress and its von Mises maxima (the yield check).
    summary: a solved state's summary, reduced on the device.
    normal_batch, tangential_batch, spectral_batch: the normal and tangential solves of B cases
        of one grid size at once, and their spectral products and padding.
    overloads: the float32 and float64 overloads of the generic kernels.
    fft: row transforms with ``tile_fft`` for the dependency-free FFT backend.
"""
