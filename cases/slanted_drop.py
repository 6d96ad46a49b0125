"""The disc or the ball of `disc_drop` / `sphere_drop` dropped on a plane tilted by
`angle`: a general gap operator (each contact row the plane's normal on a node's dofs).

The tilted scene is the untilted one in a rotated frame: every node's dofs turned by
the rotation R of `angle` in the vertical plane (x, y for the disc, x, z for the ball),
M' = Q M Q^T, K' = Q K Q^T, U0' = Q U0, G' = G Q^T (Q the block-diagonal of R), the same
gaps. With `tilt_gravity` 1 the load turns too (F' = Q F): every observable equals the
untilted scene's (contact start and end, peak force, impulse, energy; the displacement
turned back, Q^T U'), up to round-off. With `tilt_gravity` 0 gravity stays vertical (the
body force of the scheme's mass along -y or -z): the body slides down the plane while it
bounces. The contact forces are normal to the frictionless plane and K' does not act on a
rigid translation, so the momentum along the plane, p_t = t^T M' V, grows by exactly
dt t^T F' per step (each step's update of the velocity is a weighted sum of loads that
the tangent t sees only through F'), impacts included: `err_plane_momentum` is its
largest departure over the samples from p_t(0) + t_k t^T F', relative to the momentum
the body gains along the plane over the run. A base with friction (`mu` > 0) keeps it:
its tangent rows turn with the plane (downhill and, for the ball, across), so the disc
or ball bounces and slides on the slope with Coulomb friction.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.sparse as sp

from contact_bench.api.derived import DerivedScene
from contact_bench.api.params import Param
from contact_bench.api.plugin import StudyGrid
from contact_bench.api.sparse import ContactSet, SparseProblem


class SlantedDrop(DerivedScene):
    name = "slanted_drop"
    summary = "disc_drop or sphere_drop on a plane tilted by `angle` (a general gap operator)"
    params = {
        "of": Param("disc_drop[degree=1]", "the scene tilted: a disc_drop or sphere_drop spec"),
        "angle": Param(30.0, "the plane's tilt, degrees", low=-75.0, high=75.0),
        "tilt_gravity": Param(1, "1: gravity turned with the plane (the untilted scene in "
                              "a rotated frame); 0: vertical gravity (the body slides)",
                              choices=(0, 1)),
    }
    #: the scenes that can be tilted, with the index of their vertical axis
    bases = {"disc_drop": 1, "sphere_drop": 2}
    quantities = frozenset({"plane_momentum"})
    study = StudyGrid(specs=("slanted_drop[tilt_gravity=0]",), nx=(3, 5), T=14.0,
                      small="slanted_drop[of=disc_drop[degree=1,lift=0.5],tilt_gravity=0]",
                      small_nx=(2, 3), small_T=5.0, in_default_study=False)

    def rotation(self, dim: int) -> np.ndarray:
        """R (dim x dim): the turn by `angle` in the plane of the horizontal x and the
        vertical axis."""
        a = math.radians(float(self.angle))
        v = self.vertical
        R = np.eye(dim)
        R[0, 0], R[0, v], R[v, 0], R[v, v] = math.cos(a), -math.sin(a), math.sin(a), math.cos(a)
        return R

    def tangent(self, p: SparseProblem) -> np.ndarray:
        """t: the rigid translation along the plane, downhill (R e_x or -R e_x: the side
        on which gravity's tangential component points)."""
        R = self.rotation(p.dim)
        e = R[:, 0] * (1.0 if float(self.angle) <= 0.0 else -1.0)
        return np.tile(e, p.nfree // p.dim)

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> SparseProblem:
        p = self.base.sparse_problem(nx, grading, mass_kind)
        dim = p.dim
        Q = sp.csr_matrix(sp.kron(sp.identity(p.nfree // dim), self.rotation(dim)))
        # a mass that acts alike on every component (M = M_s (x) I: consistent, lumped,
        # redistributed) is the rotated body's too: kept as it is (Q M Q^T would only add
        # round-off, and off-diagonal dust to a lumped mass)
        M = sp.csr_matrix(p.M)
        if abs(sp.csr_matrix(Q @ M @ Q.T) - M).max() > 1e-12 * abs(M).max():
            M = sp.csr_matrix(Q @ M @ Q.T)
            M.eliminate_zeros()
        K = sp.csr_matrix(Q @ p.K @ Q.T)
        v = self.vertical
        if int(self.tilt_gravity):
            F = Q @ p.F
        else:  # the base's load is its mass times -g along the vertical axis: keep it so
            down = np.zeros(dim)
            down[v] = -self.base.g
            F = M @ np.tile(down, p.nfree // dim)
        c = p.contact
        G = sp.csr_matrix(c.gap_operator(p.nfree) @ Q.T)
        G.eliminate_zeros()
        # the base's friction (`mu`): its tangent rows turned as G, T' = T Q^T (downhill
        # R e_x and, for the ball, e_y), its coefficients as they are
        T = None if c.tangents is None else sp.csr_matrix(c.tangents @ Q.T)
        if T is not None:
            T.eliminate_zeros()
        contact = ContactSet(dofs=None, gap0=np.asarray(c.gap0, float),
                             weights=np.asarray(c.weights, float), face_mass=c.face_mass,
                             operator=G, tangents=T, friction=c.friction, tresca=c.tresca)
        normal_stress, shear = (None if S is None else sp.csr_matrix(S @ Q.T)
                                for S in (p.normal_stress, p.tangential_stress))
        vertical = Q @ p.vertical
        return SparseProblem(M=M, K=K, F=F, U0=Q @ p.U0, V0=Q @ p.V0, contact=contact,
                             dim=dim, hmin=p.hmin, c_max=p.c_max, mass_kind=mass_kind,
                             E_contact=p.E_contact, h_contact=p.h_contact,
                             normal_stress=normal_stress, tangential_stress=shear,
                             vertical=vertical,
                             body_mass=p.body_mass)

    def quantity_errors(self, problem, traj, row) -> dict[str, float]:
        """err_plane_momentum: max_k |p_t(t_k) - p_t(0) - t_k t^T F| over the samples,
        relative to max(|t_k t^T F|, |p_t(0)|) at the last sample (or the body's momentum
        scale m sqrt(2 g lift) when gravity has no tangential part). NaN with friction
        (the base's `mu` > 0): the plane then pushes along t too (its balance with the
        contact impulses: tests/test_slanted_friction.py)."""
        if problem.contact.frictional:
            return {"err_plane_momentum": math.nan}
        t = self.tangent(problem)
        Mt = problem.M @ t
        p_t = traj.V @ Mt
        rate = float(t @ problem.F)
        drift = p_t - p_t[0] - traj.t * rate
        lift = float(getattr(self.base, "lift", 1.0))
        scale = max(abs(rate) * float(traj.t[-1]), abs(float(p_t[0])),
                    float(problem.body_mass) * math.sqrt(2.0 * self.base.g * lift))
        return {"err_plane_momentum": float(np.max(np.abs(drift)) / scale)}
