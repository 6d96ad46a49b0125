"""A body from a mesh file (Gmsh's .msh, or what meshio reads) dropped on a rigid plane.

`file`: the mesh (P1/P2 triangles, Q1 quadrilaterals in 2D, plane strain; P1/P2
tetrahedra, Q1 hexahedra in 3D; empty: the bundled ellipse, docs/mesh-files.md);
`contact`: the named boundary group (Gmsh physical lines in 2D, faces in 3D) that may
touch the obstacle (`@facing`: the boundary facets facing it); `degree` 1 or 2 (0: the
mesh's); young (E), nu, rho; the obstacle, the plane x . normal = offset, the body on
x . normal >= offset (`normal` +x, +y, +z, `auto` the last axis); the initial
displacement `lift`, velocity `speed` (towards the plane), gravity `g`, along the
normal. `--nx`: 2 (the default, the harness's smallest) is the file's mesh; each doubling
splits every element into 2^dim (scikit-fem's `refined`: the boundary stays the file's
polygon), for P1/Q1 geometry only (scikit-fem straightens a refined P2 mesh).

Checks (one line, exit 2, before assembly): the file and group (`api.mesh_file`), the
degree, the normal, the body on the obstacle's side.
Exact references: the free fall u.n = lift - speed t - g t^2 / 2 until the first contact
(err_free_fall, relative to the lift, or to the initial gap when lift is 0); the energy
and impulse balances the harness reads for every body. A scheme's 1D mass variant maps to
its 2D/3D kind as in disc_drop (lumped refused for P2).
"""

from __future__ import annotations

import hashlib
import math
from pathlib import Path
from typing import Any

import numpy as np
import skfem as fe

from contact_bench.api import fem_nd, mesh_file
from contact_bench.api.fem import REDISTRIBUTED_KINDS, canonical_mass
from contact_bench.api.params import Param
from contact_bench.api.plugin import BodyCase, StudyGrid
from contact_bench.api.sparse import SparseProblem, sample_blocks
from contact_bench.core.errors import BenchError

#: the bundled mesh of an empty `file` (made by docs/examples/gmsh_ellipse.py)
DEFAULT_MESH = Path(__file__).parent / "meshes" / "ellipse.msh"
AXES = {"+x": 0, "x": 0, "+y": 1, "y": 1, "+z": 2, "z": 2}


class MeshBody(BodyCase):
    name = "mesh_body"
    summary = "a body from a mesh file (Gmsh .msh or what meshio reads) dropped on a plane"
    params = {
        "file": Param("", "mesh file (empty: the bundled ellipse, docs/mesh-files.md)"),
        "contact": Param("contact", "named boundary group that may touch the obstacle "
                         "(@facing: the boundary facets facing it)"),
        "degree": Param(0, "polynomial degree (0: the mesh's own order)", choices=(0, 1, 2)),
        "young": Param(50.0, "Young's modulus E", low=0.0, low_open=True),
        "nu": Param(0.25, "Poisson's ratio", low=-1.0, high=0.5, low_open=True,
                    high_open=True),
        "rho": Param(1.0, "density", low=0.0, low_open=True),
        "g": Param(0.1, "gravity towards the obstacle (per unit mass)", low=0.0),
        "lift": Param(5.0, "initial displacement away from the obstacle", low=0.0),
        "speed": Param(0.0, "initial velocity towards the obstacle"),
        "normal": Param("auto", "the obstacle's normal: +x, +y, +z (auto: the last axis)"),
        "offset": Param(0.0, "the obstacle: the plane x . normal = offset"),
        "h_contact": Param(0.0, "element size normal to the zone for penalty and Nitsche "
                           "(0: the zone elements' mean)", low=0.0),
    }
    T, nx, dt, stride = 40.0, 2, 0.01, 10
    #: the tests' and a named study's grids on the bundled ellipse (not in the default
    #: study: a user's mesh is not one of the built-in scenes)
    study = StudyGrid(specs=("mesh_body[degree=1]",), nx=(2, 4, 8), T=30.0,
                      small="mesh_body[degree=1,lift=0.5]", small_nx=(2, 4), small_T=5.0,
                      in_default_study=False)

    def validate(self) -> None:
        mf = self.mesh_file
        self.axis = self._axis(mf.dim)
        self.facets = (mesh_file.facing_facets(mf, self.axis) if self.contact == "@facing"
                       else mesh_file.boundary_group(mf, self.contact))
        order = int(self.degree) or mf.order
        try:
            fem_nd.element_for(mf.mesh, order)
        except ValueError:
            raise BenchError(f"{self.name}[degree={self.degree}]: no degree-{order} element "
                             f"on {mf.cell_type} (allowed: degree 1 or the mesh's order "
                             f"{mf.order})") from None
        X = mf.mesh.doflocs[self.axis]
        low = int(np.argmin(X))
        if X[low] < float(self.offset) - 1e-9 * self.size:
            raise BenchError(
                f"{self.name}: the body is already through the obstacle: its node {low} at "
                f"x_{self.axis} = {X[low]:.6g} < offset {float(self.offset):g} (place the "
                "mesh on the side x . normal >= offset; `lift` moves it further)")

    def _axis(self, dim: int) -> int:
        text = str(self.normal).strip().lower()
        if text == "auto":
            return dim - 1
        if text in AXES and AXES[text] < dim:
            return AXES[text]
        raise BenchError(
            f"{self.name}[normal={self.normal}]: allowed: "
            + ", ".join(k for k, a in AXES.items() if k.startswith("+") and a < dim)
            + " or auto; a negative or slanted normal needs a general gap operator, which "
            "the compiled schemes take with the one-contact-solver work (the contact set "
            "is a selection of dofs today)")

    def data_hash(self) -> str:
        """SHA-256 of the mesh file's bytes (the sweep cache runs a changed file again)."""
        return hashlib.sha256(Path(self.file or DEFAULT_MESH).read_bytes()).hexdigest()[:16]

    @property
    def mesh_file(self) -> mesh_file.MeshFile:
        return mesh_file.cached_mesh(self.file or DEFAULT_MESH)

    @property
    def dim(self) -> int:
        """The mesh file's dimension."""
        return int(self.mesh_file.dim)

    @property
    def size(self) -> float:
        """The largest extent of the mesh's bounding box."""
        p = self.mesh_file.mesh.p
        return float(np.max(p.max(axis=1) - p.min(axis=1)))

    @property
    def gap(self) -> float:
        """The smallest undeformed distance of the contact zone to the plane."""
        m = self.mesh_file.mesh
        nodes = np.unique(m.facets[:, self.facets])
        return float(np.min(m.p[self.axis, nodes]) - float(self.offset))

    @property
    def impact_time(self) -> float:
        """The first contact of the free fall: lift + gap - speed t - g t^2 / 2 = 0."""
        d, v, g = float(self.lift) + self.gap, float(self.speed), float(self.g)
        if g > 0:
            return (-v + math.sqrt(v * v + 2 * g * d)) / g
        return d / v if v > 0 else math.inf

    quantities = frozenset({"free_fall"})

    def free_fall(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, float)
        return float(self.lift) - float(self.speed) * t - 0.5 * float(self.g) * t**2

    def quantity_errors(self, problem, traj, row) -> dict[str, float]:
        """err_free_fall: the largest error of the normal displacement of any dof against
        the free fall over the samples before the first contact (less 1.5 dt), relative
        to the lift (or the initial gap when lift is 0)."""
        before = traj.t < self.impact_time - 1.5 * float(row["dt"])
        if not before.any():
            return {}
        vert = np.flatnonzero(problem.vertical > 0)
        fall = self.free_fall(traj.t)
        err = max(float(np.max(np.abs(traj.U[b][:, vert] - fall[b, None])))
                  for b in sample_blocks(int(np.count_nonzero(before)), vert.size))
        scale = float(self.lift) if float(self.lift) > 0 else max(self.gap, 1e-300)
        return {"err_free_fall": err / scale}

    def cannot_run(self, scheme) -> str | None:
        if self.degree_used == 2 and canonical_mass(scheme.mass_kind()) == "lumped":
            return ("a lumped mass on P2 elements has negative row sums at the vertices: "
                    "use mesh_body[degree=1] or the scheme's mass=consistent")
        return None

    @property
    def degree_used(self) -> int:
        return int(self.degree) or self.mesh_file.order

    def mesh(self, nx: int = 2) -> tuple[Any, np.ndarray]:
        """The mesh at nx (module docstring) and its contact facets."""
        nx = int(nx)
        k = nx.bit_length() - 2
        if nx < 2 or 2 ** (k + 1) != nx:
            raise BenchError(f"nx = {nx}: {self.name}'s mesh is the file's at nx = 2, "
                             "refined once per doubling; allowed: 2, 4, 8, ...")
        base = self.mesh_file.mesh
        if k == 0:
            return base, self.facets
        if self.mesh_file.order == 2:
            raise BenchError(f"nx = {nx}: {self.name} does not refine a P2-geometry mesh "
                             f"({self.mesh_file.cell_type}: scikit-fem's refinement "
                             "straightens it); allowed: 2 (make a finer mesh in Gmsh)")
        m = base.refined(k)
        return m, mesh_file.refined_facets(base, self.facets, m)

    def body(self, nx: int = 2) -> fem_nd.Elasticity:
        """The assembled body (its stiffness and scalar mass) at nx."""
        return fem_nd.assemble(self.mesh(nx)[0], float(self.young), float(self.nu),
                               float(self.rho), degree=self.degree_used)

    def h_zone(self, body: fem_nd.Elasticity, facets: np.ndarray) -> float:
        """The mean size normal to the zone of its elements: dim |element| / |facet| for
        simplices, |element| / |facet| for quadrilaterals and hexahedra."""
        m = body.mesh
        one = fe.Functional(lambda w: 1.0 + 0.0 * w.x[0])
        vol = one.elemental(body.full_basis())[m.f2t[0, facets]]
        area = one.elemental(fe.FacetBasis(m, body.scalar.elem, facets=facets))
        simplex = m.t.shape[0] == m.dim() + 1
        return float(np.mean(vol / area * (m.dim() if simplex else 1.0)))

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> SparseProblem:
        if grading != 1.0:
            raise ValueError(f"grading = {grading!r}: {self.name}'s mesh is the file's "
                             "(allowed: 1)")
        body = self.body(nx)
        facets = self.mesh(nx)[1]
        d, a = body.dim, self.axis
        scalar = np.unique(body.scalar.get_dofs(facets).flatten())  # for the mass
        kind = canonical_mass(mass_kind)
        M = fem_nd.mass_matrix(body, "redistributed" if kind in REDISTRIBUTED_KINDS else kind,
                               scalar)
        e = np.zeros(d)
        e[a] = 1.0
        F = fem_nd.body_force(M, d, -float(self.g) * e)
        n = body.ndofs
        vertical = np.tile(e, n // d)
        zone = fem_nd.contact_zone(body, facets, axis=a, plane=float(self.offset))
        h = float(self.h_contact) or self.h_zone(body, facets)
        return SparseProblem(M=M, K=body.K, F=F, U0=float(self.lift) * vertical,
                             V0=-float(self.speed) * vertical, contact=zone.contact_set(),
                             dim=d, hmin=body.hmin, c_max=body.wave_speed,
                             mass_kind=mass_kind, E_contact=body.lam + 2 * body.mu,
                             h_contact=fem_nd.contact_length(body, h),
                             normal_stress=zone.normal_stress, vertical=vertical,
                             body_mass=float(np.sum(M @ vertical)))
