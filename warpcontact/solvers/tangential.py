"""Partial slip: bounded conjugate gradients for the shear traction (after Chen & Wang 2008)."""

from __future__ import annotations

import warp as wp

from warpcontact.kernels import reduce
from warpcontact.kernels import tangential as tk

from ..numerics.launch import Rows, Sums
from ..numerics.state import SolveInfo
from .base import ProjectedCG, raise_non_finite


class TangentialSolver(ProjectedCG):
    """Shear traction (q_x, q_y) under the disk bound |q| <= q_max at given rigid shifts.

    Chen, W. W. & Wang, Q. J. (2008), "A numerical model for the point contact of dissimilar
    materials considering tangential tractions", Mech. Mater. 40, 936-948; their correction of
    delta_x, delta_y is not used (the shifts are inputs). See kernels/tangential.py for the
    iteration. The relative residual is the norm of the violated stick/slip conditions (stick:
    the slip increment; slip: its part not along q and any reversal) over the norm of the
    right-hand side delta - s_prev - u_known on the contact.

    Preconditioned (``preconditioned``, the default), an iteration makes one application of the
    tangential operator, K t of the conjugate direction, and carries g (g <- g - tau K t); g is
    made exact again (K q) after a released cell (a restart of the conjugacy), every
    ``exact_every`` iterations, and when the bound on what the projections changed since (slip
    cells' retraction onto their circle, stick cells projected onto it) exceeds ``deferral`` of
    the violation (``kernels/tangential.py``, ``tangential_advance``), as the normal solver
    carries its gap. The loop settles where the carried g meets the tolerance; the launch then
    makes g exact and the host judges the solve on it (going on where it does not agree). The
    direction is built from z = M g: on the stick cells M is the circulant inverse of K_tt (per
    wavenumber the inverse of the 2x2 block [[K_xx, K_xy], [K_xy, K_yy]] on the padded grid, its
    eigenvalues floored at ``eigen_floor``) applied to g on the stick cells and read there, the
    tangential analogue of the normal solver's preconditioner on its free set; on slip cells the
    Jacobi scaling of g's tangent part (1 / (self-influence + lambda / q_max)). An iteration makes
    two transform pairs (K t and M g), as the plain one does (K q and K t). Cells that slipped
    when the last solve ended start as slip cells on their new circle (``tangential_classify``'s
    ``keep_slip``). Measured on the CPU (``bench/tangential_precond.py``): one solve from rest,
    the Mindlin problem at Q / mu P = 0.5, 32, 31, 42 iterations at n = 64, 128, 256 against 65,
    86, 93 plain; the coupled step of copper on steel (Tabor k_tau = 0.8, delta_x = 2e-11 m after
    delta_z = 1e-10 m) 96, 67, 77 tangential iterations over its turns against 109, 145, 183.
    The iteration's floor in float64 lies near a relative residual of 1e-11 for both (the last
    iterations before 1e-10 can wander). Related work: Zhao, Vollebregt & Oosterlee, "A fast
    nonlinear conjugate gradient based method for 3D frictional contact problems", J. Comput.
    Phys. (2015; TU Delft report 14-02): active set, slip tractions by their azimuth angle,
    diagonal scaling, FFT products; FFT-based (circulant inverse) preconditioners for the normal
    problem: Vollebregt (2014), J. Comput. Phys. 257, 333-351, and Zhao, Vollebregt & Oosterlee
    (2014), Numer. Linear Algebra Appl. 21, 256-274.

    ``preconditioned=False``: the iteration as Chen & Wang publish it, with Jacobi scaling: K q
    for the exact gradient and K t for the step at every iteration (two applications).

    Args:
        model: the :class:`~warpcontact.numerics.model.ContactModel`.
        tol: relative residual to reach (default: 1e-10 in float64, 1e-5 in float32).
        max_iter: iteration limit; a solve that reaches it returns ``converged = False``.
        use_graphs: replay solves as CUDA graphs (default: on CUDA with conditional graph nodes).
        preconditioned: the preconditioned one-application iteration (default); False: plain.
    """

    restart_every = 100

    def __init__(self, model, tol=None, max_iter: int = 2000, use_graphs: bool | None = None,
                 preconditioned: bool = True):
        super().__init__(model, tk.N_SUMS_PRECONDITIONED, tk.N_SCALARS, tol, max_iter, use_graphs)
        f = model.field
        self.grad_x, self.grad_y = f(), f()
        self.dir_x, self.dir_y = f(), f()
        self.resp_x, self.resp_y = f(), f()
        self.no_displacement = f()
        # self-influence of the tangential kernel (scaled): the Jacobi preconditioner of stick
        # cells, and 1 / it the step of released cells when no conjugate step is defined
        k_self = 0.5 * (model.operator.self_coefficient("xx") + model.operator.self_coefficient("yy"))
        self.stiffness = model.scalar(k_self)
        self.slip_step = model.scalar(1.0 / k_self)
        #: the preconditioned iteration (class docstring); False: Chen & Wang's, two applications
        #: of the operator per iteration. A captured graph is kept per choice.
        self.preconditioned = bool(preconditioned)
        #: floor of the eigenvalues of K_tt's 2x2 blocks in the preconditioner (scaled): a
        #: quarter of the self-influence. A few entries on the padded grid's axes near the highest
        #: frequency are below it (down to -0.04; the rest 0.7 and up); floors from 0.02 to 0.5
        #: times the self-influence gave the same iterations within 1 (NumPy replay, n = 64).
        self.eigen_floor = 0.25 * k_self
        #: iterations between exact recomputations of K q in the preconditioned iteration
        self.exact_every = 50
        #: recompute K q once the bound on what the carried g misses exceeds this fraction of the
        #: violation. A captured graph keeps the value it was captured with.
        self.deferral = 0.1
        self._column_norm = model.scalar(model.operator.tangential_column_norm())
        self.deferred = model.scalars(1)
        #: 1: the next iteration starts from an exact g (set by the device)
        self.recompute = wp.zeros(1, dtype=wp.int32, device=model.device)
        self._current_sums = self.sums[: tk.S_RHS + 1]  # slots S_G, S_VIOL, S_RHS
        #: launches of the last preconditioned solve that settled on a carried g whose exact
        #: value did not meet the tolerance (the loop then went on from the exact g)
        self.disagreements = 0

    def solve(self, state, target_x, target_y, shear_limit, known_x=None, known_y=None, tol=None) -> SolveInfo:
        """Solve for ``state.shear_x/y`` and ``state.status``.

        Args:
            state: holds the shear to start from (and the statuses the last solve left); its
                ``disp_x/y`` receive K_tt q.
            target_x, target_y: delta - s_prev [scaled]: where stick cells must stay.
            shear_limit: q_max per cell [scaled].
            known_x, known_y: tangential displacement from other tractions held fixed (the
                pressure's coupling term K_tp p), scaled; zero if None.
        """
        known_x = known_x if known_x is not None else self.no_displacement
        known_y = known_y if known_y is not None else self.no_displacement
        if self.preconditioned:
            return self._solve_preconditioned(state, target_x, target_y, shear_limit, known_x, known_y, tol)
        return self._solve_plain(state, target_x, target_y, shear_limit, known_x, known_y, tol)

    def _fields(self, state, target_x, target_y, shear_limit, known_x, known_y):
        """The fields flattened, marked as the CPU splits the reducing passes over its threads."""
        return tuple(Rows(a.flatten()) for a in (
            state.shear_x, state.shear_y, state.status, state.disp_x, state.disp_y, known_x, known_y, target_x,
            target_y, shear_limit, self.grad_x, self.grad_y, self.dir_x, self.dir_y, self.resp_x, self.resp_y))

    def _key(self, state, target_x, target_y, shear_limit, known_x, known_y):
        return (self.preconditioned, *(a.ptr for a in (state.shear_x, state.shear_y, state.status, state.disp_x,
                                                       state.disp_y, known_x, known_y, target_x, target_y,
                                                       shear_limit)))

    def _on_non_finite(self, state):
        def on_non_finite(it):
            raise_non_finite("tangential solve", state, ("shear_x", "shear_y", "disp_x", "disp_y"), it)

        return on_non_finite

    def _solve_preconditioned(self, state, target_x, target_y, shear_limit, known_x, known_y, tol) -> SolveInfo:
        m = self.model
        fft = m.operator.fft
        qx, qy, st, ux, uy, kx, ky, tgx, tgy, limit, gx, gy, tx, ty, rx, ry = self._fields(
            state, target_x, target_y, shear_limit, known_x, known_y)
        sums = Sums(self.sums)
        self._stage(tk.P_EXACT, 0.0)
        self._begin(tol)
        self.disagreements = 0
        output = [Rows(fft.padded_output), fft.output_scale]  # M g, as the preconditioner leaves it
        shape = m.grid.shape

        def start():
            self.dir_x.zero_()  # no leftover from an earlier (possibly failed) solve
            self.dir_y.zero_()
            m.launch_cells(tk.tangential_classify, [limit, 1], [qx, qy, st])

        def residual():  # g and slots S_G (slip part), S_VIOL, S_RHS from state.disp = K q
            m.launch_reduce(tk.tangential_residual, [ux, uy, kx, ky, tgx, tgy, qx, qy, limit, st, self.stiffness],
                            [gx, gy, sums])

        def displacement():
            m.operator.tangential(state.shear_x, state.shear_y, state.disp_x, state.disp_y)

        def exact():
            displacement()
            residual()
            self.recompute.zero_()
            self.deferred.zero_()

        def recompute():  # the prelude of an iteration where the device asked for an exact g
            self._current_sums.zero_()
            displacement()
            residual()

        def stick_gradient(grad):  # one component of g on the stick cells into the padded input
            return lambda: m.launches.launch_rows(tk.tangential_stick_gradient, shape,
                                                  [Rows(grad.flatten()), st, m.grid.n], [Rows(fft.padded_input)])

        def direction_x():
            m.launches.launch_rows(tk.tangential_direction_stick, shape,
                                   [*output, st, self.sums, self.scalars, m.grid.n], [tx])

        def direction_rest():
            m.launches.launch_rows(tk.tangential_direction_rest, shape,
                                   [*output, gx, gy, qx, qy, limit, st, self.stiffness, self.sums, self.scalars,
                                    m.grid.n],
                                   [tx, ty])

        def body():  # after recompute() where self.recompute is set (the device decides: _run's prelude)
            m.operator.tangential_inverse_padded(stick_gradient(self.grad_x), stick_gradient(self.grad_y),
                                                 direction_x, direction_rest, self.sums, tk.S_G, self.eigen_floor)
            m.operator.tangential(self.dir_x, self.dir_y, self.resp_x, self.resp_y)
            m.launch_reduce(tk.tangential_step_sums, [gx, gy, tx, ty, rx, ry, qx, qy, limit, st], [sums])
            m.launch_reduce(tk.tangential_carried_update,
                            [tx, ty, rx, ry, limit, self.slip_step, self.stiffness, self.settings],
                            [qx, qy, st, gx, gy, sums])
            m.launch(tk.tangential_advance, 1,
                     [self.sums, self.settings, self.restart_every, self.exact_every, self._column_norm,
                      m.scalar(self.deferral)],
                     [self.scalars, self.history, self.deferred, self.recompute, self.loop, self.refresh,
                      self.inner_loop])

        def on_disagreement():  # the carried g said "converged", the exact one does not: go on from it
            self.disagreements += 1

        key = self._key(state, target_x, target_y, shear_limit, known_x, known_y)
        return self._run(key, start, exact, body, self._on_non_finite(state), on_disagreement,
                         prelude=(self.recompute, recompute))

    def _solve_plain(self, state, target_x, target_y, shear_limit, known_x, known_y, tol) -> SolveInfo:
        m = self.model
        qx, qy, st, ux, uy, kx, ky, tgx, tgy, limit, gx, gy, tx, ty, rx, ry = self._fields(
            state, target_x, target_y, shear_limit, known_x, known_y)
        sums = Sums(self.sums)
        self._begin(tol)

        def start():
            self.dir_x.zero_()  # no leftover from an earlier (possibly failed) solve
            self.dir_y.zero_()
            m.launch_cells(tk.tangential_classify, [limit, 0], [qx, qy, st])

        def gradient():
            m.operator.tangential(state.shear_x, state.shear_y, state.disp_x, state.disp_y)
            m.launch_reduce(tk.tangential_gradient, [ux, uy, kx, ky, tgx, tgy, qx, qy, limit, st, self.stiffness],
                            [gx, gy, sums])

        def body():
            self.sums.zero_()
            gradient()
            m.launch_cells(tk.tangential_direction,
                           [gx, gy, qx, qy, limit, st, self.stiffness, self.sums, self.scalars], [tx, ty])
            m.operator.tangential(self.dir_x, self.dir_y, self.resp_x, self.resp_y)
            m.launch_reduce(tk.tangential_step_sums, [gx, gy, tx, ty, rx, ry, qx, qy, limit, st], [sums])
            m.launch_reduce(tk.tangential_update, [gx, gy, tx, ty, limit, self.slip_step, self.settings],
                            [qx, qy, st, sums])
            m.launch(reduce.cg_advance, dim=1, inputs=[self.sums, self.settings, self.restart_every],
                     outputs=[self.scalars, self.history, self.loop, self.refresh])

        key = self._key(state, target_x, target_y, shear_limit, known_x, known_y)
        return self._run(key, start, gradient, body, self._on_non_finite(state))

