"""Cases with friction and the SMC law solved together (``warpcontact.solve_batch``, the batched
gross-slip searches): the batched lagged turns carry each case's adhesive tractions, and each
case's result is what ``warpcontact.solve`` (its own search) gives it."""

import pytest

import warpcontact as wc
import warpcontact.physics.adhesion as adhesion_laws
from test_solve_batch import DEVICES, quiet
from test_solve_batch_friction import assert_same_path, case, handed_back

#: an SMC law on the DMT side of its Maugis parameter (0.05 on the small case's sphere and pair:
#: the single solver's turns are lagged, as the batch's)
SMC = {"law": "smc", "sigma_max": 20e6, "tau_max": 20e6, "delta_n": 2e-10, "delta_t": 2e-10}

#: one mixed batch: the Tabor law on a dissimilar pair with adhesion, a weaker law, Coulomb on
#: another pair with adhesion, identical materials with adhesion (uncoupled: the turns are the
#: adhesive fixed point's alone), the hardness cap with adhesion, and a case without adhesion
MIXED = [
    case(adhesion=SMC),
    case(adhesion={**SMC, "sigma_max": 10e6, "tau_max": 5e6}),
    case(adhesion=SMC, friction={"law": "coulomb", "mu": 0.3}, flat={"E": 120e9, "nu": 0.35}),
    case(adhesion=SMC, flat={"E": 200e9, "nu": 0.3, "yield_strength": 3e9}),
    case(adhesion=SMC, flat={"hardness": 1.2e9}, friction={"law": "tabor", "k_tau": 0.9, "hardness_cap": True},
         load={"path": [[0, 0, 1.5e-9], [3e-10, 0, 1.5e-9]]}),
    case(),
]


@pytest.fixture
def unique_tractions(monkeypatch):
    """The SMC law without its touching segment (``adhesion.TOUCHING`` = 0). With it, a cell out
    of contact within 1 % of delta_n of the other surface may carry any traction between the
    law's and none, and keeps the one its turns left it: the solution is not unique there, and
    two ways of turning (the batch's, the single solver's) can end on different points of the
    segment (measured on these cases: forces up to 1.4e-4 of |F_z| apart; Table 2's adhesive mu at
    n = 32 up to 1.3e-4). Without it the fixed point is unique, and the two must meet on it."""
    monkeypatch.setattr(adhesion_laws, "TOUCHING", 0.0)


@pytest.mark.parametrize("device", DEVICES)
def test_a_batch_of_adhesive_cases_gives_each_what_solve_gives(device, unique_tractions):
    """The six cases of ``MIXED`` in one batch, float64, none handed back to be solved on its own:
    every state's forces within 1e-9 of |F_z| of solve's, the contact, stick and adhesive areas
    identical (cell counts). Both solve each inner problem to 1e-10 and end their turns where the
    tractions, the adhesive ones included, change by less than 1e-8 a turn; each mixes the
    adhesive tractions by Anderson's method from the same start (measured: 8.9e-11 at most)."""
    from warpcontact.studies import batch_solve

    own = batch_solve.run_path
    batch_solve.run_path = None  # a case handed back to be solved on its own would fail here
    try:
        batched = quiet(wc.solve_batch, MIXED, device=device, batch=len(MIXED))
    finally:
        batch_solve.run_path = own
    for c, result in zip(MIXED, batched):
        assert not isinstance(result, Exception), result
        single = quiet(wc.solve, c, device=device, fields="none")
        assert_same_path(result, single, rel=1e-9)
        for a, b in zip(result.states, single.states):
            assert a["adhesive_area"] == b["adhesive_area"]
    assert batched[0].states[-1]["adhesive_area"] > 0


def test_only_lagged_smc_cases_are_batched():
    """The batch turns as the single solver's lagged turns do: an SMC law past the DMT side (the
    single solver minimises its turns), the law's shear added in the contact, another law, or
    adhesion without friction are solved on their own."""
    from warpcontact.studies.batch_solve import batchable

    assert batchable(wc.case_from_dict(MIXED[0]))
    assert batchable(wc.case_from_dict(MIXED[4]))  # the hardness cap: lagged turns whatever the law
    assert not batchable(wc.case_from_dict(case(adhesion={**SMC, "sigma_max": 40e6})))
    assert not batchable(wc.case_from_dict(case(adhesion={**SMC, "contact_shear": "added"})))
    assert not batchable(wc.case_from_dict(case(adhesion={"law": "dugdale", "sigma_0": 20e6, "h_0": 2e-10})))
    no_friction = case(adhesion=SMC)
    del no_friction["friction"]
    assert not batchable(wc.case_from_dict(no_friction))


def test_batched_adhesive_searches_give_each_its_own_search(unique_tractions):
    """Two adhesive gross-slip searches walking together (``gross_slip_batch``) on the CPU: each
    ends where its own search ends (the same states, delta_x_max) with mu within 1e-8 (the
    forces' agreement above, in a ratio of two of them)."""
    from warpcontact.studies.batch_solve import gross_slip_batch
    from warpcontact.studies.tasks import gross_slip_summary, prepare

    cases = [prepare(wc.case_from_dict(c)) for c in MIXED[:2]]
    results = quiet(gross_slip_batch, cases, batch=2)
    for c, entry in zip(cases, results):
        assert not isinstance(entry, Exception), entry
        summary, _ = entry
        own = quiet(gross_slip_summary, c)
        assert summary["converged"] and own["converged"]
        assert (summary["delta_x_max"], len(summary["states"])) == (own["delta_x_max"], len(own["states"]))
        assert summary["mu"] == pytest.approx(own["mu"], rel=1e-8)


def test_table2_batches_its_adhesive_cells_only_where_the_batched_turns_carry_the_law(tmp_path):
    """``warpcontact table2 --batch B`` searches its adhesive cells together with the SMC law of
    its defaults (the DMT side), and leaves them to be searched one at a time with the law's shear
    added in the contact or a law past the DMT side (the single solver's turns are minimised)."""
    from warpcontact.studies.table2 import Table2Run, Table2Settings

    def batched(**law):
        run = Table2Run(Table2Settings(n=32, **law), tmp_path, k_tau=(0.8,), delta_z_um=(1e-4,))
        return [c[3] for _, c in run._batched_cells(2)[0]]

    assert batched() == [False, True]
    assert batched(contact_shear="added") == []  # one cell left: nothing to batch
    assert batched(sigma_max=1e9, tau_max=1e9) == []


def test_float32_adhesive_batches_agree_with_float64():
    """Three adhesive cases batched in float32 (tolerance 1e-5 on the relative residual): every
    state's forces within 1e-4 of |F_z| of float64's single solve (the residual's tolerance and
    float32's rounding of the sums, as for cases without adhesion; measured 6.5e-6) and the stick
    areas identical."""
    batched = quiet(wc.solve_batch, MIXED[:3], dtype="float32", batch=3)
    for c, result in zip(MIXED[:3], batched):
        assert not isinstance(result, Exception), result
        assert result.model.dtype_name == "float32" and result.converged
        single = quiet(wc.solve, c, fields="none")
        for a, b in zip(result.states, single.states):
            assert all(abs(a["force"][k] - b["force"][k]) <= 1e-4 * abs(b["force"]["z"]) for k in "xyz")
            assert a["stick_area"] == b["stick_area"]


def test_an_adhesive_case_whose_batched_step_does_not_converge_is_solved_on_its_own(monkeypatch):
    """An adhesive case whose batched turns cannot converge (one inner iteration a solve to 1e-12)
    is handed back from the batch and solved on its own, where the single solver's fallbacks
    (the lagged turns from zero tractions, then the minimised turns, whose adhesive minimisation
    has an iteration limit of its own) take it on: its states are solve's, to the last digit; the
    adhesive case beside it is still solved in the batch."""
    alone = handed_back(monkeypatch)
    hard = case(adhesion=SMC, solver={"max_iter": 1, "tol": 1e-12}, load={"path": [[0, 0, 1e-9]]})
    results = quiet(wc.solve_batch, [MIXED[1], hard], batch=2)
    assert len(alone) == 1 and alone[0].solver.max_iter == 1
    single = quiet(wc.solve, hard, fields="none")
    assert [(s["converged"], s["force"]["z"]) for s in results[1].states] == \
        [(s["converged"], s["force"]["z"]) for s in single.states]
    assert_same_path(results[0], quiet(wc.solve, MIXED[1], fields="none"), rel=1e-6)


def test_yield_checks_made_together_take_the_adhesive_tractions(unique_tractions, monkeypatch):
    """On CUDA the cases of a batch that end at a state check their yield together
    (``batch_solve._yield_checks``), from the batch's rows of the contact tractions gathered with
    the adhesive ones added: the totals each case's own check takes (``yielding._state_totals``).
    The same evaluation forced on the CPU (``checks_by_planes``, so the single solves check by
    planes too), for two adhesive cases and one without adhesion in one batch: each case's largest
    von Mises stress and its depth within 1e-8 of its own solve's (``assert_same_path``; the
    adhesive tractions left out move the largest stress by 1.2e-3 here)."""
    from warpcontact.numerics import yielding

    monkeypatch.setattr(yielding, "checks_by_planes", lambda model: True)
    cases = [MIXED[0], MIXED[3], MIXED[5]]
    batched = quiet(wc.solve_batch, cases, device="cpu", batch=len(cases))
    for c, result in zip(cases, batched):
        assert not isinstance(result, Exception), result
        assert_same_path(result, quiet(wc.solve, c, device="cpu", fields="none"), rel=1e-9)
