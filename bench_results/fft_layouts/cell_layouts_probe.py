import sys, time
import warp as wp
wp.config.quiet = True
wp.init()
import warpcontact.fft.cupy_backend as cb
from warpcontact.table2 import Table2Settings, table2_cell
s = Table2Settings(n=256, device="cuda:0")
table2_cell(0.8, 1e-4, s, adhesion=True)
orig = cb.prune_by_default
for dz in (1e-4, 1e-5):
    for name, f in (("pruned", lambda *a: True), ("2-D", lambda *a: False), ("pruned", lambda *a: True)):
        cb.prune_by_default = f
        t0 = time.perf_counter(); r = table2_cell(0.8, dz, s, adhesion=True)
        print(f"cell 0.8 {dz} adhesive grid {r['grid_n']} layout {name}: {time.perf_counter()-t0:.2f} s, mu {r['mu']:.6f}, dx {r['delta_x_max_um']:.5e}", flush=True)
