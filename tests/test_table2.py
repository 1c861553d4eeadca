"""The paper's Table 2, adhesionless columns: mu within 3 %, delta_x_max within 5 % of the paper.

delta_x_max is the lower end of a bisection bracket 1 % wide; the paper prints two significant
digits of it (4.2e-6 means 4.15e-6 ... 4.25e-6, +-1.2 %).
"""

import pytest

from warpcontact.table2 import Table2Settings, cells, table2_cell

# one cell per regime: bond failure (Tabor) only, mixed, von Mises dominated
CI_CELLS = [(0.80, 5.0e-5), (0.50, 1.5e-4), (0.95, 1.5e-4)]


def check(rec):
    assert rec["converged"], rec
    assert abs(rec["rel_diff_mu"]) < 0.03, f"mu {rec['mu']:.4f} vs paper {rec['paper_mu']} ({100 * rec['rel_diff_mu']:+.1f} %)"
    assert abs(rec["rel_diff_delta_x_max"]) < 0.05, (
        f"delta_x_max {rec['delta_x_max_um']:.3e} um vs paper {rec['paper_delta_x_max_um']} "
        f"({100 * rec['rel_diff_delta_x_max']:+.1f} %)")


@pytest.mark.parametrize("k_tau, delta_z_um", CI_CELLS)
def test_table2_cell(k_tau, delta_z_um):
    check(table2_cell(k_tau, delta_z_um, Table2Settings(n=64)))


@pytest.mark.slow
@pytest.mark.parametrize("k_tau, delta_z_um", cells())
def test_table2_converged_in_the_grid(k_tau, delta_z_um):
    """Every cell at two resolutions: both meet the paper, and mu moves by under 0.5 % between
    them (grid convergence; delta_x_max is quantised by its 1 % bracket)."""
    coarse = table2_cell(k_tau, delta_z_um, Table2Settings(n=64))
    fine = table2_cell(k_tau, delta_z_um, Table2Settings(n=128))
    check(coarse)
    check(fine)
    assert abs(fine["mu"] / coarse["mu"] - 1) < 5e-3
    assert abs(fine["delta_x_max_um"] / coarse["delta_x_max_um"] - 1) <= 0.0101
