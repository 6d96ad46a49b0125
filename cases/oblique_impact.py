"""The disc or the ball of `disc_drop` / `sphere_drop` hitting the rigid plane obliquely,
with Coulomb friction `mu` and no gravity (the impulses are then the contact's alone).

The body starts undeformed at the base's `lift` above the plane, moving at `speed`
towards it and at speed tan(`incidence`) along x (`incidence`: the angle of the impact
velocity from the normal, degrees). The base's contact points each get the tangent
rows of the plane (e_x; in 3D e_x, e_y: the circular cone) and the coefficient mu.
Observables from the FE field (`rigid_motion`): the centre-of-mass velocity E^T M V / m
and the spin, (W^T M W)^-1 W^T M V, W the infinitesimal rotations about the centre of
mass of the discrete mass (K W = 0 on the ball and the P2 disc: a constant spin in flight).

Exact identities (no gravity, K E = 0): the change of momentum dP is the contact
impulse. In gross sliding every touching point (gap <= 0) slides along +x at every sample,
its friction is -mu times its normal force: `err_impulse_ratio`, (|dP_t| / dP_n - mu) / mu
(NaN if a touching point does not slide). With mu = 0: `err_tangential_momentum`, |dP_t| /
dP_n. The rebound against Maw-Barber-Fawcett's theory: `rebound`, docs/oblique-impact.md.
"""

from __future__ import annotations

import math

import numpy as np

from contact_bench.api.derived import DerivedScene
from contact_bench.api.params import Param
from contact_bench.api.plugin import StudyGrid
from contact_bench.api.registry import make_case
from contact_bench.api.sparse import SparseProblem
from contact_bench.core.errors import BenchError


class ObliqueImpact(DerivedScene):
    name = "oblique_impact"
    summary = "disc_drop or sphere_drop hitting the plane obliquely, Coulomb friction mu"
    params = {
        "of": Param("sphere_drop[lift=0.0505]", "the body: a disc_drop or sphere_drop spec "
                    "(its lift: the initial gap)"),
        "mu": Param(0.0, "Coulomb's friction coefficient (0: frictionless, every scheme "
                    "runs it)", low=0.0, high=10.0),
        "incidence": Param(60.0, "the impact velocity's angle from the normal, degrees",
                           low=0.0, high=89.99),
        "speed": Param(0.1, "the normal impact speed", low=1e-6, high=100.0),
    }
    bases = {"disc_drop": 1, "sphere_drop": 2}
    quantities = frozenset({"impulse_ratio", "tangential_momentum"})
    study = StudyGrid(specs=("oblique_impact[mu=0.3]",), nx=(2, 4), T=None,
                      small="oblique_impact[of=disc_drop[degree=1,lift=0.0505]]",
                      small_nx=(2, 3), small_T=5.0, in_default_study=False,
                      friction=("oblique_impact[mu=0.3]",), friction_stability_T=75.0)

    def validate(self) -> None:
        super().validate()
        if float(self.base.mu) != 0.0:
            raise BenchError(f"{self.spec}: of = {self.of!r} sets mu; give the friction as "
                             "oblique_impact's mu")
        if float(self.mu) > 0.0:  # the base's own frictional plane (its tangents, shear)
            s, mu = self.base.spec, f"mu={float(self.mu)!r}"
            self.base = make_case(f"{s[:-1]},{mu}]" if s.endswith("]") else f"{s}[{mu}]")
        # the free flight to the plane, the contact (about 30 on the ball at the default
        # speed; Hertz's duration goes as speed^-1/5), and as long again after it
        self.T = float(self.impact_time + 70.0 * (0.1 / float(self.speed)) ** 0.2)

    @property
    def impact_time(self) -> float:
        """The free flight's end: lift / speed."""
        return float(self.base.lift) / float(self.speed)

    @property
    def exact_energy(self) -> float | None:
        return None

    @property
    def poisson_ratio(self) -> float:
        """The body's Poisson ratio lambda / (2 (lambda + mu_l)) from its Lame constants
        (not the friction coefficient `mu`)."""
        return float(self.base.lam) / (2.0 * (float(self.base.lam) + float(self.base.mu_l)))

    def velocity(self) -> np.ndarray:
        """The impact velocity (dim,): speed tan(incidence) along x, -speed vertically."""
        v = np.zeros(self.dim)
        v[0] = float(self.speed) * math.tan(math.radians(float(self.incidence)))
        v[self.vertical] = -float(self.speed)
        return v

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> SparseProblem:
        p = self.base.sparse_problem(nx, grading, mass_kind)
        d = self.dim
        n = p.nfree
        return SparseProblem(M=p.M, K=p.K, F=np.zeros(n), U0=p.U0,
                             V0=np.tile(self.velocity(), n // d), contact=p.contact, dim=d,
                             hmin=p.hmin, c_max=p.c_max, mass_kind=mass_kind,
                             equal_groups=() if self.velocity()[0] else p.equal_groups,
                             E_contact=p.E_contact, h_contact=p.h_contact,
                             normal_stress=p.normal_stress,
                             tangential_stress=p.tangential_stress,
                             vertical=p.vertical, body_mass=p.body_mass)

    def rigid_fields(self, problem: SparseProblem, nx: int) -> tuple[np.ndarray, np.ndarray]:
        """(E, W): the unit translations (dim, n) and the infinitesimal rotations about
        the discrete mass's centre (1 or 3, n; 2D: about z; 3D: about x, y, z)."""
        d, n = self.dim, problem.nfree
        X = np.asarray(self.base.body(nx).dof_coordinates, float).T.ravel()
        E = np.array([np.tile(np.eye(d)[k], n // d) for k in range(d)])
        ME = problem.M @ E.T
        centre = (X @ ME) / np.sum(E.T * ME, axis=0)
        r = (X - np.tile(centre, n // d)).reshape(-1, d)
        if d == 2:
            W = np.column_stack([-r[:, 1], r[:, 0]]).ravel()[None, :]
        else:
            W = np.array([np.cross(np.eye(3)[k], r).ravel() for k in range(3)])
        return E, W

    def rigid_motion(self, problem: SparseProblem, traj, nx: int) -> dict[str, np.ndarray]:
        """Per sample: the centre-of-mass velocity `v` (K, dim), the momentum `P` (K,
        dim) and the spin `omega` (K, 1 or 3): the angular momentum W^T M V through the
        inertia tensor W^T M W of the discrete mass."""
        E, W = self.rigid_fields(problem, nx)
        MV = problem.M @ np.asarray(traj.V).T  # (n, K)
        P = (E @ MV).T
        mass = np.sum(E * (problem.M @ E.T).T, axis=1)
        inertia = W @ (problem.M @ W.T)
        omega = np.linalg.solve(inertia, W @ MV).T
        return {"v": P / mass, "P": P, "omega": omega}

    def rebound(self, problem: SparseProblem, traj, nx: int) -> dict[str, float]:
        """Before (the first sample) and after (the last: the run ends in free flight)
        the impact: the normal and tangential
        centre velocities, the spin about the axis across the motion (2D: z; 3D: y,
        signed so that friction against a +x slip makes it positive), the contact point's
        tangential velocity (centre plus spin times R), k^2 = I / (m R^2) of the discrete
        mass, and Maw-Barber-Fawcett's psi1, psi2 and Omega (`contact_bench.exact.
        oblique`, with the body's Poisson ratio). The disc's P1 elements on its curved
        (P2-geometry) mesh do not hold a rotation exactly (K W != 0): its spin moves with
        its vibration after the impact; the ball's straight tetrahedra and P2 hold it."""
        rm = self.rigid_motion(problem, traj, nx)
        v, om = rm["v"][[0, -1]], rm["omega"][[0, -1], -1 if self.dim == 2 else 1]
        spin = -om if self.dim == 2 else om  # friction along -x turns the body this way
        R, nu = float(self.base.R), self.poisson_ratio
        _, W = self.rigid_fields(problem, nx)
        w = W[-1 if self.dim == 2 else 1]
        mass = float(problem.body_mass)
        k2 = float(w @ (problem.M @ w)) / (mass * R * R)
        vn1, vn2 = -v[0, self.vertical], v[1, self.vertical]
        c1, c2 = v[0, 0] - spin[0] * R, v[1, 0] - spin[1] * R
        kap = 2 * (1 - nu) / (2 - nu)
        mu = float(self.mu)
        out = {"vn_before": vn1, "vn_after": vn2, "vt_before": v[0, 0], "vt_after": v[1, 0],
               "spin_after": spin[1], "contact_vt_before": c1, "contact_vt_after": c2,
               "k2": k2, "nu": nu}
        if mu > 0:
            out.update(psi1=kap * c1 / (mu * vn1), psi2=kap * c2 / (mu * vn2),
                       Omega=spin[1] * R / (mu * vn1))
        return {k: float(x) for k, x in out.items()}

    def quantity_errors(self, problem, traj, row) -> dict[str, float]:
        """err_impulse_ratio and err_tangential_momentum (module docstring): from the
        momentum's change over the run, dP_n its vertical part, dP_x along x (in 3D the
        tangential part's length)."""
        E, _ = self.rigid_fields(problem, int(row["nx"]))
        dP = E @ (problem.M @ (np.asarray(traj.V[-1]) - np.asarray(traj.V[0])))
        v = self.vertical
        dn = float(dP[v])
        dt_ = float(np.linalg.norm(np.delete(dP, v)))
        mu = float(self.mu)
        out = {"err_impulse_ratio": math.nan, "err_tangential_momentum": math.nan}
        if not dn > 0:
            return out
        if mu == 0.0:
            out["err_tangential_momentum"] = dt_ / dn
            return out
        c = problem.contact
        nt = c.tangents.shape[0] // c.size
        slip = (np.asarray(traj.V) @ c.tangents.T)[:, ::nt]  # along x
        gap = np.asarray(c.gap0) + np.asarray(traj.U) @ c.gap_operator(problem.nfree).T
        touching = gap <= 1e-12 * float(np.max(np.abs(c.gap0)))
        if np.all(slip[touching] > 0.0):
            out["err_impulse_ratio"] = abs(dt_ / dn - mu) / mu
        return out
