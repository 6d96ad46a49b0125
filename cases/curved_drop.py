"""The body of `hertz_sphere`, `disc_drop` or `sphere_drop` hitting a rigid sphere (a
circle in 2D) of radius `R_o` instead of the plane: a curved obstacle, its gaps
|x + u - c| - R_o nonlinear in u (`contact_bench.core.obstacle.Sphere`).

The sphere's top is where the base's plane was, under the body's vertical axis: c = (0,
level - R_o) (3D: (0, 0, level - R_o)), the level read from the base's gaps. The contact
points are the base's, each with all its displacement components (the axisymmetric
ball's pole keeps u_r = 0: held); hertz_sphere's meridian circle is a sphere on the axis.
The compiled schemes step it through a tangent gap operator updated at each step's
contact-free prediction (docs/contact.md); a scheme whose stepper cannot is not applicable
(`Scheme.follows_curved_obstacle`: nitsche, taylor_flanagan, the explicit penalty).

References: with `of=hertz_sphere`, Hertz's impact of two spheres, the ball (radius R) and
the rigid one (R_o): the plane's formulas with R* = R R_o / (R + R_o) and the ball's mass
(`hertz`; Johnson 1985, sec. 11), err_hertz_contact_time and err_hertz_peak_force as in
`hertz_sphere` (a model, the limit v / c -> 0). As R_o grows the gaps tend to the
plane's (they differ by |x_t|^2 / (2 R_o) at a point x_t off the axis), so every
observable tends to the base scene's (tests/test_curved_drop.py).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from contact_bench.api.derived import DerivedScene
from contact_bench.api.params import Param
from contact_bench.api.plugin import StudyGrid
from contact_bench.api.sparse import ContactSet, SparseProblem
from contact_bench.core.obstacle import sphere, sphere_gaps
from contact_bench.exact.hertz import HertzImpact


class CurvedDrop(DerivedScene):
    name = "curved_drop"
    summary = "a ball or disc on a rigid sphere / circle of radius R_o (curved obstacle)"
    params = {
        "of": Param("hertz_sphere", "the scene whose plane becomes the sphere"),
        "R_o": Param(1.0, "the obstacle's radius", low=1e-3, high=1e12),
    }
    #: the scenes whose plane can be replaced, with the index of their vertical axis
    bases = {"hertz_sphere": 1, "disc_drop": 1, "sphere_drop": 2}
    quantities = frozenset({"hertz_contact_time", "hertz_peak_force"})
    # the quick study and the tests on the disc: the adaptive reference (DOP853) crawls
    # through the ball's nonlinear gaps
    study = StudyGrid(specs=("curved_drop",), nx=(2, 3), T=None,
                      small="curved_drop[of=disc_drop[degree=1,lift=0.5]]",
                      small_nx=(2, 3), small_T=5.0, in_default_study=False)

    def validate(self) -> None:
        super().validate()
        if self.base.name == "hertz_sphere":
            self.T = round(1.25 * self.hertz().contact_time, 1)
        else:  # Hertz's model is the axisymmetric ball's: no reference quantity here
            self.quantities = frozenset()

    def cannot_run(self, scheme) -> str | None:
        if not scheme.follows_curved_obstacle():
            return ("the scheme's stepper keeps its gap operator fixed for the run "
                    "(Scheme.follows_curved_obstacle)")
        if self.friction() > 0:
            return (f"friction (mu = {self.friction():g}) on the curved obstacle (R_o = "
                    f"{float(self.R_o):g}): the frictional steppers keep their normal and "
                    "tangent rows fixed for the run")
        return self.base.cannot_run(scheme)

    def hertz(self) -> HertzImpact:
        """Hertz's impact of the base's ball on the rigid sphere: the effective radius R*
        = R R_o / (R + R_o) and the ball's own mass (the density scaled by (R / R*)^3,
        so that HertzImpact's mass rho 4/3 pi R*^3 is the ball's)."""
        b = self.base
        R, Ro = float(b.R), float(self.R_o)
        Rs = R * Ro / (R + Ro)
        return HertzImpact(R=Rs, E=b.Young, nu=b.nu, rho=b.rho * (R / Rs) ** 3,
                           v=float(b.v))

    def points(self, p: SparseProblem, nx: int) -> tuple[np.ndarray, np.ndarray]:
        """(position, component) of every free dof: the base's `dof_points` (and its
        vertical dofs for the component), else its body's nodes, dofs interleaved."""
        if "dof_points" in p.extra:
            return (np.asarray(p.extra["dof_points"], float),
                    np.asarray(p.vertical, float).astype(np.int64))
        P = np.asarray(self.base.body(nx).dof_coordinates, float)
        return np.repeat(P, p.dim, axis=1), np.arange(p.nfree) % p.dim

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> SparseProblem:
        p = self.base.sparse_problem(nx, grading, mass_kind)
        c, dim, v = p.contact, p.dim, self.vertical
        X, comp = self.points(p, nx)
        sel = c.selected_dofs("curved_drop")
        level = float(np.mean(X[v, sel] - c.gap0))
        # each contact point's dofs: the free dofs at its position, by component
        key = {}
        for k in range(p.nfree):
            key[(*np.round(X[:, k], 12), int(comp[k]))] = k
        dofs = np.full((sel.size, dim), -1, np.int64)
        for j, k in enumerate(sel):
            for a in range(dim):
                dofs[j, a] = key.get((*np.round(X[:, k], 12), a), -1)
        centre = np.zeros(dim)
        centre[v] = level - float(self.R_o)
        ob = sphere(centre, float(self.R_o), X[:, sel].T, dofs)
        g0 = sphere_gaps(ob, np.zeros(p.nfree))
        normals = (ob.points - centre) / (g0 + ob.radius)[:, None]
        rows, cols = np.nonzero(dofs >= 0)
        G = sp.csr_matrix((normals[rows, cols], (rows, dofs[rows, cols])),
                          shape=(sel.size, p.nfree))
        contact = ContactSet(dofs=None, gap0=g0, weights=np.asarray(c.weights, float),
                             face_mass=c.face_mass, operator=G, obstacle=ob)
        return SparseProblem(M=p.M, K=p.K, F=p.F, U0=p.U0, V0=p.V0, contact=contact,
                             dim=dim, hmin=p.hmin, c_max=p.c_max, mass_kind=mass_kind,
                             equal_groups=p.equal_groups, E_contact=p.E_contact,
                             h_contact=p.h_contact, normal_stress=None,
                             vertical=p.vertical, body_mass=p.body_mass)

    def quantity_errors(self, problem, traj, row) -> dict[str, float]:
        """With `of=hertz_sphere`: the relative gaps to Hertz's contact time (first
        contact start to end, both interpolated within their steps) and peak force of the
        two spheres."""
        if self.base.name != "hertz_sphere":
            return {}
        h = self.hertz()
        out = {}
        if row.get("first_contact_end") is not None and np.isfinite(row["first_contact_end"]):
            tc = row["first_contact_end"] - row["first_contact_start"]
            out["err_hertz_contact_time"] = abs(tc / h.contact_time - 1.0)
        if row.get("peak_contact_force") is not None:
            out["err_hertz_peak_force"] = abs(row["peak_contact_force"] / h.peak_force - 1.0)
        return out
