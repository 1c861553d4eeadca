"""Partial slip: bounded conjugate gradients for the shear traction (after Chen & Wang 2008)."""

from __future__ import annotations


from warpcontact.kernels import reduce
from warpcontact.kernels import tangential as tk

from ..launch import Rows, Sums
from ..state import SolveInfo
from .base import ProjectedCG, raise_non_finite


class TangentialSolver(ProjectedCG):
    """Shear traction (q_x, q_y) under the disk bound |q| <= q_max at given rigid shifts.

    Chen, W. W. & Wang, Q. J. (2008), "A numerical model for the point contact of dissimilar
    materials considering tangential tractions", Mech. Mater. 40, 936-948; their correction of
    delta_x, delta_y is not used (the shifts are inputs). See kernels/tangential.py for the
    iteration. The relative residual is the norm of the violated stick/slip conditions (stick:
    the slip increment; slip: its part not along q and any reversal) over the norm of the
    right-hand side delta - s_prev - u_known on the contact.
    """

    restart_every = 100

    def __init__(self, model, tol=None, max_iter: int = 2000, use_graphs: bool | None = None):
        super().__init__(model, tk.N_SUMS, tk.N_SCALARS, tol, max_iter, use_graphs)
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

    def solve(self, state, target_x, target_y, shear_limit, known_x=None, known_y=None, tol=None) -> SolveInfo:
        """Solve for ``state.shear_x/y`` and ``state.status``.

        Args:
            state: holds the shear to start from; its ``disp_x/y`` receive K_tt q.
            target_x, target_y: delta - s_prev [scaled]: where stick cells must stay.
            shear_limit: q_max per cell [scaled].
            known_x, known_y: tangential displacement from other tractions held fixed (the
                pressure's coupling term K_tp p), scaled; zero if None.
        """
        m = self.model
        known_x = known_x if known_x is not None else self.no_displacement
        known_y = known_y if known_y is not None else self.no_displacement
        # the fields flattened, marked as the CPU splits the reducing passes over its threads (by rows)
        qx, qy, st, ux, uy, kx, ky, tgx, tgy, limit, gx, gy, tx, ty, rx, ry = (Rows(a.flatten()) for a in (
            state.shear_x, state.shear_y, state.status, state.disp_x, state.disp_y, known_x, known_y, target_x,
            target_y, shear_limit, self.grad_x, self.grad_y, self.dir_x, self.dir_y, self.resp_x, self.resp_y))
        sums = Sums(self.sums)
        self._begin(tol)

        def start():
            self.dir_x.zero_()  # no leftover from an earlier (possibly failed) solve
            self.dir_y.zero_()
            m.launch_cells(tk.tangential_classify, [limit], [qx, qy, st])

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
            m.launch_reduce(tk.tangential_update, [gx, gy, tx, ty, limit, self.slip_step, self.settings], [qx, qy, st, sums])
            m.launch(reduce.cg_advance, dim=1, inputs=[self.sums, self.settings, self.restart_every],
                     outputs=[self.scalars, self.history, self.loop, self.refresh])

        key = tuple(a.ptr for a in (state.shear_x, state.shear_y, state.status, state.disp_x, state.disp_y, known_x,
                                    known_y, target_x, target_y, shear_limit))

        def on_non_finite(it):
            raise_non_finite("tangential solve", state, ("shear_x", "shear_y", "disp_x", "disp_y"), it)

        return self._run(key, start, gradient, body, on_non_finite)
