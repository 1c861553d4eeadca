"""Maugis-Dugdale approach-retraction curve with the adhesive minimisation, against the reference.

    python validation/adhesive_curve.py LAMBDA N [float64|float32] [SMOOTHING] [DEVICE]

Dugdale law (R = 1 um, w = 0.5 J/m^2, ramps of SMOOTHING h_0, default 0.05), domain 5 a0, 12 steps each way; prints
each state's iterations, residual and force with Maugis-Dugdale's at the same approach and branch,
then the pull-off against Maugis-Dugdale's and the grid's cell_softening.
"""
import math
import sys
import time

import numpy as np
from warpcontact.physics.adhesion import Dugdale, SMC
from warpcontact.physics.geometry import Grid, Sphere
from warpcontact.physics.materials import PAPER_PAIR
from warpcontact.numerics.model import ContactModel
from warpcontact.numerics.state import ContactState
from warpcontact.solvers.adhesive import AdhesiveNormalSolver
from warpcontact.physics.reference import maugis_dugdale_force_at, maugis_dugdale_pull_off, maugis_dugdale_scales
from warpcontact.physics.adhesion import cell_softening
lam, n = float(sys.argv[1]), int(sys.argv[2]); dtype = sys.argv[3] if len(sys.argv) > 3 else "float64"
smoothing = float(sys.argv[4]) if len(sys.argv) > 4 else 0.05
device = sys.argv[5] if len(sys.argv) > 5 else "cpu"
R, w = 1e-6, 0.5
Es = PAPER_PAIR.E_star
sigma0 = lam / (9 * R / (2 * math.pi * w * Es**2)) ** (1 / 3)
law = Dugdale(sigma_0=sigma0, h_0=w / sigma0, smoothing=smoothing)
a0 = (9 * math.pi * w * R**2 / (2 * Es)) ** (1 / 3)
model = ContactModel(PAPER_PAIR, Sphere(R), Grid(n, 5 * a0), dtype=dtype, device=device)
solver = AdhesiveNormalSolver(model, law)
state = ContactState(model)
h0 = law.h_0
dzs = np.concatenate([np.linspace(-h0, 2 * h0, 13), np.linspace(2 * h0, -3 * h0, 13)[1:]])
approach_unit = maugis_dugdale_scales(Es, R, w, sigma0)["approach"]
print(f"lambda {lam} n {n} smoothing {smoothing} cell_softening {cell_softening(law, model):.2f} {device} {dtype}")
F = []; t0 = time.time()
for k, dz in enumerate(dzs):
    info = solver.solve(state, dz)
    f = (state.pressure.numpy().astype(float) + state.adhesive_pressure.numpy()).sum() * Es * model.grid.dx**2
    F.append(f)
    ref = maugis_dugdale_force_at(lam, dz / approach_unit, "approach" if k < 13 else "retract")
    print(f"{dz/h0:+.2f} it {info.iterations} conv {info.converged} res {info.residual:.1e} F/piRw {f/(math.pi*R*w):+.4f} "
          f"MD {ref:+.4f} tr {solver.transforms}", flush=True)
print(f"pull-off {min(F)/(math.pi*R*w):.4f} ref {maugis_dugdale_pull_off(lam):.4f} {time.time()-t0:.1f}s")
