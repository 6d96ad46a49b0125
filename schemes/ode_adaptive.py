"""The paper's Lipschitz ODE (P_U^mod) by scipy's DOP853 with error control: the reference.

The same ODE as `ode_verlet` (Dabaghi, Petrov, Pousin, Renard 2014, section 4: node 0
massless and eliminated, u0 = max(0, (F0 - K01 u1) / K00)), as a first-order system for
`scipy.integrate.solve_ivp(method="DOP853")` with relative tolerance `rtol` and absolute
tolerance rtol x (max|U0| + `velocity_scale`). The right-hand side is a numba function
(one tridiagonal solve with the reduced mass, factored once); the samples come from
DOP853's dense output at the sample times.

dt is only the sampling interval: the integrator picks its own steps, so `steps` in the
results is T / dt and `Trajectory.extra` carries `nfev` and the solver's message. It is
the accuracy reference in time, not a speed contender. Its declared bounds and their
measurements: docs/schemes.md. On the general sparse problem: the same integrator on
the dofs with mass, the massless ones (with exact contact) solved at every evaluation
(`contact_bench.kernels.sparse_family.adaptive_sparse`).
"""

from __future__ import annotations

import numpy as np

from contact_bench.api.fem import MASS_ALIASES, REDISTRIBUTED_KINDS
from contact_bench.api.params import Param
from contact_bench.api.plugin import (
    CallStepper,
    Contact,
    Energy,
    Scheme,
    Stepper,
    Traits,
    Trajectory,
    on_curved_obstacle,
)
from contact_bench.api.problem import banded
from contact_bench.core.sampling import BLOWUP_FACTOR, n_samples
from contact_bench.core.tridiag import factor_pt
from contact_bench.kernels.common import velocity_scale
from contact_bench.kernels.massless_ode import ode_rhs
from contact_bench.kernels.sparse_family import prepare_adaptive


class OdeAdaptive(Scheme):
    name = "ode_adaptive"
    summary = "the paper's ODE (P_U^mod) by DOP853 with error control (dt = sampling only)"
    params = {
        "rtol": Param(1e-8, "relative tolerance of DOP853", low=1e-13, high=1e-2, quick=1e-5),
        "variant": Param("first_element_massless", "where the first element's mass goes",
                         choices=REDISTRIBUTED_KINDS, aliases=MASS_ALIASES),
    }

    def mass_kind(self) -> str:
        return self.variant

    def traits(self, problem=None) -> Traits:
        return Traits(implicit=False, massless_contact_node=True, contact=Contact.EXACT,
                      energy=Energy.MAY_GROW if on_curved_obstacle(problem)
                      else Energy.CONSERVED, order=None, adaptive=True)

    def energy_drift_bound(self, problem, dt: float) -> float | None:
        return 1e3 * self.rtol

    def follows_curved_obstacle(self) -> bool:
        return True  # its sparse stepper re-linearises the gaps every step

    def adds_time_load(self) -> bool:
        return True  # the ODE's right-hand side adds it at the integrator's stage times

    def prepare(self, problem, dt: float) -> Stepper:
        # a body: DOP853 on the dofs with mass, the massless ones solved from their rows
        # (`contact_bench.kernels.sparse_family.adaptive_sparse`)
        semi = banded(problem)
        if semi is not None:
            return CallStepper(lambda n, s: self.run_bar(semi, dt, n, s))
        return prepare_adaptive(problem, dt, float(self.rtol))

    def run_bar(self, semi, dt: float, nsteps: int, stride: int) -> Trajectory:
        """The bar's ODE by DOP853 (`ode_rhs` on the tridiagonal bands)."""
        M, K, F = semi.M, semi.K, semi.F
        n = semi.nfree
        Sd, Se = factor_pt(M.diag[1:], M.off[1:])
        steps = np.arange(0, nsteps + 1, stride)
        if steps[-1] != nsteps:
            steps = np.append(steps, nsteps)
        assert steps.size == n_samples(nsteps, stride)
        t_eval = steps * dt
        y0 = np.concatenate([semi.U0[1:], semi.V0[1:]])
        atol = self.rtol * (float(np.max(np.abs(semi.U0))) + velocity_scale(semi) + 1e-300)
        args = (K.diag, K.off, F, Sd, Se)
        from scipy.integrate import solve_ivp  # here: 20 MB that other schemes' runs skip

        sol = solve_ivp(lambda t, y: ode_rhs(y, *args), (0.0, float(t_eval[-1])), y0,
                        method="DOP853", t_eval=t_eval, rtol=self.rtol, atol=atol)
        k = sol.t.size
        U = np.zeros((k, n))
        V = np.zeros((k, n))
        U[:, 1:] = sol.y[: n - 1].T
        V[:, 1:] = sol.y[n - 1:].T
        u0 = (F[0] - K.off[0] * U[:, 1]) / K.diag[0]
        U[:, 0] = np.maximum(u0, 0.0)
        V[:, 0] = np.where(u0 > 0.0, -(K.off[0] / K.diag[0]) * V[:, 1], 0.0)
        lam = K.diag[0] * U[:, 0] + K.off[0] * U[:, 1] - F[0]
        energy = 0.5 * M.quad(V) + 0.5 * K.quad(U) - U @ F + semi.energy_offset
        blow = None
        bad = ~np.isfinite(energy) | (np.abs(energy) > BLOWUP_FACTOR * max(abs(energy[0]), 1e-300))
        if bad.any():
            first = int(np.argmax(bad))
            blow, k = float(sol.t[first]), first + 1
        elif sol.status != 0:
            blow = float(sol.t[-1]) if k else 0.0
        return Trajectory(
            t=sol.t[:k], U=U[:k], V=V[:k], contact_u=U[:k, 0], stress=-lam[:k],
            energy=energy[:k], min_contact_u=float(U[:k, 0].min()) if k else 0.0,
            steps_done=int(steps[k - 1]) if k else 0, blowup_time=blow,
            extra={"nfev": int(sol.nfev), "message": str(sol.message), "rtol": self.rtol},
        )

