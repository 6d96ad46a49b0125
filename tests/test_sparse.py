"""The general sparse problem: 2D/3D assembly, mass variants, the sparse
schemes' exact contact, and the embedded bar against its 1D scene."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import skfem as fe

from contact_bench.api import fem_nd
from contact_bench.api.registry import make_case, schemes
from contact_bench.api.sparse import ContactSet, SparseProblem
from contact_bench.core import ordering
from contact_bench.core.errors import BenchError
from contact_bench.harness.runner import run_one
from contact_bench.kernels.sparse import (
    Factor,
    central_sparse,
    lcp_solve,
    newmark_sparse,
    quasistatic_sparse,
)
from contact_bench.schemes.redistributed import Redistributed


def _moments(Ms: sp.spmatrix, X: np.ndarray) -> np.ndarray:
    vecs = [np.ones(X.shape[1]), *X]
    return np.array([a @ (Ms @ b) for a in vecs for b in vecs])


# ------------------------------------------------------------------ assembly, masses


@pytest.mark.parametrize("dim", [2, 3])
def test_q1_mass_is_the_kronecker_product_and_k_keeps_the_bar(dim):
    x = np.array([0.0, 0.3, 0.5, 1.0, 1.4])
    y = np.linspace(0.0, 1.0, 3)
    mesh = fe.MeshQuad.init_tensor(x, y) if dim == 2 else fe.MeshHex.init_tensor(x, y, y)
    body = fem_nd.assemble(mesh, 2.0, 0.0, 1.5)
    M = fem_nd.mass_matrix(body, "consistent")
    Mk = fem_nd.mass_matrix(body, "kron:consistent")
    assert abs(M - Mk).max() < 1e-14 * abs(M).max()
    assert abs(fem_nd.mass_matrix(body, "lumped") - fem_nd.mass_matrix(body, "kron:lumped")
               ).max() < 1e-14
    u = np.zeros(body.ndofs)
    u[0::dim] = np.sin(body.dof_coordinates[0])  # u = (u1(x), 0, 0)
    r = body.K @ u
    for c in range(1, dim):
        assert abs(r[c::dim]).max() < 1e-13 * abs(r).max()
    assert M.sum() == pytest.approx(dim * 1.5 * 1.4)  # total mass of each component


def test_lumped_mass_row_sums_and_p2_refused():
    body = fem_nd.assemble(fe.MeshTri1.init_circle(2), 50.0, 0.25, 1.0)
    lm = fem_nd.mass_matrix(body, "lumped")
    assert lm.nnz == body.ndofs and np.all(lm.diagonal() > 0)
    np.testing.assert_allclose(lm.diagonal(), np.asarray(fem_nd.mass_matrix(
        body, "consistent").sum(axis=1)).ravel(), rtol=1e-14)
    p2 = fem_nd.assemble(fe.MeshTri2.init_circle(1), 50.0, 0.25, 1.0, degree=2)
    assert np.asarray(p2.Ms.sum(axis=1)).min() < 0  # why it is refused
    with pytest.raises(ValueError, match="negative"):
        fem_nd.mass_matrix(p2, "lumped")


@pytest.mark.parametrize("mesh, degree", [
    (fe.MeshTri1.init_circle(3), 1),
    (fe.MeshTri2.init_circle(2), 2),
    (fe.MeshTet.init_ball(2), 1),
], ids=["P1 disc", "P2 disc", "P1 ball"])
def test_redistributed_mass_keeps_moments_zero_rows_and_spd(mesh, degree, monkeypatch):
    body = fem_nd.assemble(mesh, 50.0, 0.25, 2.0, degree)
    zone = body.boundary_facets(lambda x: x[1] < -0.5)
    contact = np.unique(body.scalar.get_dofs(zone).flatten())
    assert contact.size >= 5
    R = fem_nd.redistributed(body, contact)
    X = body.dof_coordinates
    before, after = _moments(body.Ms, X), _moments(R, X)
    np.testing.assert_allclose(after, before, rtol=0, atol=1e-13 * np.abs(before).max())
    assert abs(R - R.T).max() == 0.0
    assert abs(R[contact]).max() == 0.0 and abs(R[:, contact]).max() == 0.0
    rest = np.setdiff1d(np.arange(X.shape[1]), contact)
    block = R[rest][:, rest].toarray()  # small: an independent check of SPD
    assert np.linalg.eigvalsh(block).min() > 0
    assert fem_nd.is_spd(R[rest][:, rest]) and not fem_nd.is_spd(R)
    # the same answers with the nested-dissection ordering (used from
    # NESTED_DISSECTION_DOFS rows on, here forced on the small matrices)
    if ordering.pymetis is not None:
        monkeypatch.setattr(ordering, "NESTED_DISSECTION_DOFS", 0)
        assert ordering.is_spd(R[rest][:, rest]) and not ordering.is_spd(R)
    # the vector mass: zero rows at every component of the contact nodes
    V = fem_nd.mass_matrix(body, "redistributed", contact)
    assert np.all(V.diagonal()[body.dim * contact] == 0)


@pytest.mark.parametrize("dim", [2, 3])
def test_redistribution_changes_the_mass_near_the_contact_face_only(dim):
    """Entries between dofs two element neighbourhoods or more away from the contact zone
    keep the consistent mass bit for bit (its upper triangle, which the result mirrors);
    one neighbourhood cannot keep the second moments on a flat face (its nodes lie at one
    height), so a second is taken."""
    mesh = (fe.MeshTri.init_tensor(*[np.linspace(0, 1, 9)] * 2) if dim == 2
            else fe.MeshTet.init_tensor(*[np.linspace(0, 1, 5)] * 3))
    body = fem_nd.assemble(mesh, 1.0, 0.3, 1.0)
    X = body.dof_coordinates
    contact = np.flatnonzero(np.isclose(X[dim - 1], 0.0))
    h = 1.0 / (8 if dim == 2 else 4)
    for layers in (1, 2):  # asked for one: grown to two
        R = fem_nd.redistributed(body, contact, layers=layers)
        np.testing.assert_allclose(_moments(R, X), _moments(body.Ms, X), rtol=0,
                                   atol=1e-13 * np.abs(_moments(body.Ms, X)).max())
        far = np.flatnonzero(X[dim - 1] > 2.5 * h)  # beyond the second layer
        D = sp.triu(R - body.Ms, format="csr")[far][:, far]  # (the upper triangle is mirrored)
        assert abs(D).max() == 0.0
        near = np.flatnonzero(np.isclose(X[dim - 1], 2 * h))
        assert abs((R - body.Ms)[near]).max() > 0  # the second layer does change
    with pytest.raises(ValueError, match="layers must be at least 1; got 0"):
        fem_nd.redistributed(body, contact, layers=0)


def test_redistribution_written_for_the_symmetric_unknowns_matters():
    """Symmetrising a solution of the unsymmetric constraints breaks the first moment:
    the check above can fail (here: each entry moved alone, not its mirror)."""
    body = fem_nd.assemble(fe.MeshTri1.init_circle(2), 50.0, 0.25, 1.0)
    contact = np.unique(body.scalar.get_dofs(body.boundary_facets(
        lambda x: x[1] < -0.5)).flatten())
    R = fem_nd.redistributed(body, contact).tolil()
    i, j = (int(k) for k in np.argwhere(sp.triu(R, 1).toarray() != 0)[0])
    R[i, j] += 1e-3  # an unsymmetric change, symmetrised: the moments move
    R = sp.csr_matrix(0.5 * (R + R.T))
    X = body.dof_coordinates
    assert np.abs(_moments(R, X) - _moments(body.Ms, X)).max() > 1e-5


def _ball_contact(nx: int):
    """sphere_drop's ball (radius 20 about z = 20) and the scalar dofs of its lower half."""
    body = make_case("sphere_drop").body(nx)
    zone = body.boundary_facets(lambda x: x[2] < 19.8)
    return body, np.unique(body.scalar.get_dofs(zone).flatten())


def test_the_coarse_balls_redistributed_mass_is_spd_where_a_positive_diagonal_exists():
    """At nx 4 the ball's contact dofs carry 22 % of the mass and the least change of
    every entry is indefinite (smallest eigenvalue -69 of the non-contact block; the
    construction refused it), yet a positive diagonal mass keeps the moments: the
    mass on the segment between them keeps every moment, zero contact rows, and a
    non-contact block no closer to singular than the consistent mass's (eigenvalues by
    numpy, not by the factorisation the construction reads). At nx 2 no positive diagonal
    exists (12 non-contact dofs): refused in one line."""
    body, contact = _ball_contact(4)
    ev = fem_nd.redistribution_evidence(body, contact)
    assert ev["lambda_min"] < 0 < ev["diagonal_margin"]
    R = fem_nd.redistributed(body, contact)
    X = body.dof_coordinates
    before = _moments(body.Ms, X)
    np.testing.assert_allclose(_moments(R, X), before, rtol=0,
                               atol=1e-12 * np.abs(before).max())
    assert abs(R - R.T).max() == 0.0 and abs(R[contact]).max() == 0.0
    rest = np.setdiff1d(np.arange(X.shape[1]), contact)
    smallest = np.linalg.eigvalsh(R[rest][:, rest].toarray()).min()
    consistent = np.linalg.eigvalsh(body.Ms[rest][:, rest].toarray()).min()
    assert smallest >= consistent * (1 - 1e-6) and smallest <= consistent * 1.01
    body, contact = _ball_contact(2)
    assert np.isnan(fem_nd.redistribution_evidence(body, contact)["diagonal_margin"])
    with pytest.raises(ValueError, match=r"on the 12 non-contact scalar dofs \(of 25\)") as e:
        fem_nd.redistributed(body, contact)
    assert "\n" not in str(e.value)


# ------------------------------------------------------------ Dirichlet and sliding


def _plane(c: int, at: float):
    return lambda x: np.isclose(x[c], at)


def _box(dim: int, kind: str) -> fem_nd.Elasticity:
    mesh = {"tri": fe.MeshTri().refined(1), "quad": fe.MeshQuad().refined(1),
            "tet": fe.MeshTet(), "hex": fe.MeshHex()}[kind]
    assert mesh.dim() == dim
    return fem_nd.assemble(mesh, 1.0, 0.3, 1.0, degree=2 if kind in ("tri", "tet") else 1)


#: (dim, element, sliding planes (axis, at), clamped planes, zero modes left):
#: the rigid motions that the constraints allow (translations along a sliding plane,
#: rotations about its normal axis when it is the only one)
RIGID = [
    (2, "tri", [], [], 3), (2, "quad", [(0, 0.0)], [], 1), (2, "tri", [(0, 0.0), (0, 1.0)], [], 1),
    (2, "quad", [(0, 0.0), (1, 0.0)], [], 0), (2, "tri", [], [(0, 0.0)], 0),
    (3, "hex", [], [], 6), (3, "tet", [(0, 0.0)], [], 3), (3, "hex", [(0, 0.0), (0, 1.0)], [], 3),
    (3, "tet", [(0, 0.0), (1, 1.0)], [], 1), (3, "hex", [(0, 0.0), (1, 0.0), (2, 0.0)], [], 0),
    (3, "tet", [], [(2, 1.0)], 0),
]


@pytest.mark.parametrize("dim, kind, sliding, clamped, modes", RIGID)
def test_constrain_leaves_the_rigid_motions_the_constraints_allow(dim, kind, sliding, clamped,
                                                                  modes):
    from scipy.sparse.linalg import eigsh

    body = _box(dim, kind)
    M = fem_nd.mass_matrix(body, "consistent")
    red = fem_nd.constrain(body, M, np.zeros(body.ndofs),
                           dirichlet=[fem_nd.Dirichlet(_plane(*q)) for q in clamped],
                           sliding=[_plane(*q) for q in sliding])
    # the smallest eigenvalues of K x = lambda M x (shift-invert below zero: K singular)
    lam = eigsh(red.K.tocsc(), k=8, M=red.M.tocsc(), sigma=-1.0, which="LM",
                return_eigenvectors=False)
    assert np.count_nonzero(np.abs(lam) < 1e-8) == modes
    assert np.sort(np.abs(lam))[modes] > 1e-3  # the others are clearly not zero
    # an allowed translation (along every sliding plane, none clamped) is in ker K
    if modes and not clamped:
        t = np.zeros(body.ndofs)
        c = next(c for c in range(dim) if all(c != q[0] for q in sliding))
        t[c::dim] = 1.0
        assert np.abs(red.K @ t[red.free]).max() < 1e-12


@pytest.mark.parametrize("kind", ["tri", "hex"])
def test_constrain_prescribed_values_give_the_whole_body_energy(kind):
    body = _box(2 if kind == "tri" else 3, kind)
    dim, n = body.dim, body.ndofs
    rng = np.random.default_rng(3)
    M = fem_nd.mass_matrix(body, "consistent")
    F = rng.normal(size=n)
    red = fem_nd.constrain(body, M, F, sliding=[_plane(1, 0.0)], dirichlet=[
        fem_nd.Dirichlet(_plane(0, 0.0), values=[0.3, 0.0, 0.1][:dim]),
        fem_nd.Dirichlet(_plane(0, 1.0), components=[0], values=0.05)])
    assert np.count_nonzero(red.lifted) > 0 and red.energy_offset != 0.0
    D = np.setdiff1d(np.arange(n), red.free)
    assert np.all(red.lifted[red.free] == 0.0)
    for _ in range(2):  # a quadratic equal at every point: K, F and offset all right
        U = rng.normal(size=red.free.size)
        V = rng.normal(size=red.free.size)
        Ue, Ve = red.expand(U), np.zeros(n)
        Ve[red.free] = V  # the prescribed dofs at rest
        whole = 0.5 * Ve @ (M @ Ve) + 0.5 * Ue @ (body.K @ Ue) - F @ Ue
        reduced = 0.5 * V @ (red.M @ V) + 0.5 * U @ (red.K @ U) - red.F @ U + red.energy_offset
        assert reduced == pytest.approx(whole, rel=1e-12, abs=1e-12 * abs(whole))
    # the values where they were asked for
    X = body.dof_coordinates
    s = np.flatnonzero(np.isclose(X[0], 1.0))
    assert np.all(red.lifted[dim * s] == 0.05) and set(dim * s) <= set(D)


def test_constrain_refuses_a_slanted_plane_and_two_values():
    mesh = fe.MeshTri(np.array([[0.0, 1.0, 1.0, 0.0], [0.0, 0.0, 1.0, 1.5]]),
                      np.array([[0, 1, 2], [0, 2, 3]]).T)
    body = fem_nd.assemble(mesh, 1.0, 0.3, 1.0)
    M = fem_nd.mass_matrix(body, "consistent")
    top = body.boundary_facets(lambda x: x[1] >= 1.0 - 1e-12)
    assert top.size == 1
    with pytest.raises(ValueError, match=f"sliding facet {top[0]} .* no axis-aligned plane"):
        fem_nd.constrain(body, M, np.zeros(body.ndofs), sliding=[top])
    disc = fem_nd.assemble(fe.MeshTri2.init_circle(1), 1.0, 0.3, 1.0)  # curved facets
    with pytest.raises(ValueError, match="no axis-aligned plane"):
        fem_nd.constrain(disc, disc.K, np.zeros(disc.ndofs), sliding=[lambda x: x[1] < -0.5])
    with pytest.raises(ValueError, match="two values"):
        fem_nd.constrain(body, M, np.zeros(body.ndofs), sliding=[_plane(0, 0.0)],
                         dirichlet=[fem_nd.Dirichlet(_plane(0, 0.0), values=1.0)])


# ------------------------------------------------------------------ the contact zone

ZONES = [  # (mesh, degree, zone predicate, axis, zone measure)
    (fe.MeshTri().refined(2), 1, lambda x: x[1] < 1e-9, 1, 1.0),
    (fe.MeshTri().refined(1), 2, lambda x: x[0] < 1e-9, 0, 1.0),
    (fe.MeshTri2.init_circle(2), 2, lambda x: x[1] < -0.3, 1, None),
    (fe.MeshQuad.init_tensor(np.array([0.0, 0.4, 1.0]), np.array([0.0, 0.3, 1.0])), 1,
     lambda x: x[1] < 1e-9, 1, 1.0),
    (fe.MeshTet().refined(1), 1, lambda x: x[2] < 1e-9, 2, 1.0),
    (fe.MeshTet().refined(1), 2, lambda x: x[1] < 1e-9, 1, 1.0),
    (fe.MeshHex().refined(1), 1, lambda x: x[2] < 1e-9, 2, 1.0),
]


@pytest.mark.parametrize("mesh, degree, where, axis, measure", ZONES,
                         ids=["P1 tri", "P2 tri", "P2 disc", "Q1 quad", "P1 tet", "P2 tet",
                              "Q1 hex"])
def test_contact_zone_normal_stress_is_exact_for_uniform_strains(mesh, degree, where, axis,
                                                                 measure):
    body = fem_nd.assemble(mesh, 3.0, 0.3, 1.0, degree)
    plane = float(np.min(body.dof_coordinates[axis])) - 0.25
    zone = fem_nd.contact_zone(body, where, axis, plane=plane)
    X, d = body.dof_coordinates, body.dim
    assert zone.dofs.size >= 3 and np.all(zone.dofs % d == axis)
    np.testing.assert_allclose(zone.gap0, X[axis, zone.scalar] - plane, rtol=0, atol=0)
    rng = np.random.default_rng(1)
    for _ in range(3):
        A = rng.normal(size=(d, d))
        U = np.ravel((A @ X).T) + rng.normal()  # a linear field (plus a translation)
        eps = 0.5 * (A + A.T)
        sigma = body.lam * np.trace(eps) + 2 * body.mu * eps[axis, axis]
        np.testing.assert_allclose(zone.normal_stress @ U, sigma, rtol=0,
                                   atol=1e-10 * abs(sigma) + 1e-12)
    # (P2 triangle faces: the vertices' weights are zero, up to round-off)
    np.testing.assert_allclose(np.asarray(zone.face_mass.sum(axis=1)).ravel(), zone.weights,
                               rtol=0, atol=1e-13 * zone.weights.max())
    if measure is not None:
        assert zone.weights.sum() == pytest.approx(measure, rel=1e-13)


def test_contact_zone_of_the_disc_is_the_dense_projection():
    """The disc's operator against the dense solve it replaced: M_f^-1 G, with G assembled
    here by scikit-fem independently of fem_nd."""
    from skfem.helpers import sym_grad, trace

    p = make_case("disc_drop[degree=2]").sparse_problem(2, 1.0, "consistent")
    body = make_case("disc_drop[degree=2]").body(2)
    facets = body.boundary_facets(lambda x: x[1] < 20.0 - 0.2)
    fb = fe.FacetBasis(body.mesh, body.scalar.elem, facets=facets)
    fv = fe.FacetBasis(body.mesh, fe.ElementVector(body.scalar.elem), facets=facets,
                       quadrature=(fb.X, fb.W))
    G = fe.BilinearForm(lambda u, v, _: (body.lam * trace(sym_grad(u)) + 2 * body.mu
                                         * sym_grad(u)[1, 1]) * v).assemble(fv, fb).tocsr()
    s = p.contact.dofs // 2
    Mf = fe.BilinearForm(lambda u, v, _: u * v).assemble(fb).toarray()[s][:, s]
    dense = np.linalg.solve(Mf, G[s].toarray())
    assert np.abs(dense - p.normal_stress.toarray()).max() < 1e-12 * np.abs(dense).max()
    assert np.abs(Mf - p.contact.face_mass.toarray()).max() == 0.0


def test_contact_zone_refuses_a_crossed_plane_and_eliminated_dofs():
    body = fem_nd.assemble(fe.MeshQuad().refined(1), 1.0, 0.3, 1.0)
    with pytest.raises(ValueError, match="crosses the plane"):
        fem_nd.contact_zone(body, lambda x: x[1] < 1e-9, 1, plane=0.1)
    zone = fem_nd.contact_zone(body, lambda x: x[1] < 1e-9, 1)
    red = fem_nd.constrain(body, body.K, np.zeros(body.ndofs), sliding=[lambda x: x[1] < 1e-9])
    with pytest.raises(ValueError, match="eliminated"):
        zone.contact_set(red.free)


# ------------------------------------------------------------------- solver pieces


def test_factor_solves_and_lcp_is_complementary():
    rng = np.random.default_rng(1)
    A = sp.random(120, 120, density=0.03, random_state=2)
    S = (A @ A.T + sp.identity(120)).tocsr()
    b = rng.standard_normal(120)
    assert abs(S @ Factor.of(S).solve(b) - b).max() < 1e-12
    for _ in range(20):
        B = rng.standard_normal((9, 9))
        W = B @ B.T + 0.1 * np.eye(9)
        q = rng.standard_normal(9)
        mu, active = np.zeros(9), np.zeros(9, bool)
        assert lcp_solve(W, q, mu, active, 1e-14) >= 0
        g = q + W @ mu
        assert mu.min() >= 0 and g.min() > -1e-12 and abs(mu * g).max() < 1e-12


def _disc_problem(mass: str) -> SparseProblem:
    """A small P1 disc (radius 1) lifted 0.05 above y = 0 and falling (g = 1)."""
    body = fem_nd.assemble(fe.MeshTri1.init_circle(2), 50.0, 0.25, 1.0)
    X = body.dof_coordinates
    zone = body.boundary_facets(lambda x: x[1] < -0.6)
    cs = np.unique(body.scalar.get_dofs(zone).flatten())
    M = fem_nd.mass_matrix(body, mass, cs)
    F = fem_nd.body_force(fem_nd.mass_matrix(body, "consistent"), 2, np.array([0.0, -1.0]))
    U0 = np.zeros(body.ndofs)
    U0[1::2] = 0.05
    return SparseProblem(M=M, K=body.K, F=F, U0=U0, V0=np.zeros(body.ndofs),
                         contact=ContactSet(2 * cs + 1, X[1, cs] + 1.0, np.ones(cs.size)),
                         dim=2, hmin=body.hmin, c_max=body.wave_speed)


@pytest.mark.parametrize("mass", ["consistent", "redistributed"])
def test_sparse_newmark_no_penetration_complementarity_and_energy(mass):
    p = _disc_problem(mass)
    p.check()
    dt, nsteps = 0.01, 120  # contact from t ~ 0.3 on
    tr = newmark_sparse(p, dt, nsteps, 1, 0.25, 0.5)
    assert tr.blowup_time is None and tr.steps_done == nsteps
    gaps = p.gaps(tr.U)
    assert gaps.min() >= -1e-12 and tr.min_contact_u >= -1e-12  # exact contact
    assert tr.extra["first_contact_start"] == pytest.approx(0.32, abs=0.03)
    # the contact force: lambda = M A + K U - F on the contact dofs, >= 0, and zero
    # where the gap is open (complementarity), at every step (stride 1)
    A = np.diff(tr.V, axis=0) / dt  # mean acceleration over each step
    if mass == "redistributed":  # contact dofs massless: lambda = (K U - F) exactly
        lam = (p.K @ tr.U[1:].T).T[:, p.contact.dofs] - p.F[p.contact.dofs]
        scale = np.abs(lam).max()
        assert lam.min() > -1e-9 * scale
        assert np.abs(lam * gaps[1:]).max() < 1e-9 * scale * 0.05
        drift = np.abs(tr.energy - tr.energy[0]).max() / abs(tr.energy[0])
        assert drift < 0.05  # conserved between switches, small at switches
    else:
        assert np.isfinite(A).all()
    assert tr.extra["peak_contact_force"] > 0 and tr.stress.min() < 0


def test_sparse_central_difference_stops_contact_dofs_and_dissipates():
    p = _disc_problem("lumped")
    dt = 0.1 * p.hmin / p.c_max  # well below the limit: the sampled energy's own
    # central-difference excess r^2 / (1 - r^2) (r = dt / limit) stays negligible
    nsteps = int(0.6 / dt)
    tr = central_sparse(p, dt, nsteps, 1)
    assert tr.blowup_time is None and tr.extra["first_contact_start"] < 0.4
    assert p.gaps(tr.U).min() >= -1e-12 and tr.min_contact_u >= -1e-12  # never penetrates
    assert tr.energy.max() <= tr.energy[0] * (1 + 1e-9)  # stopping dofs only removes energy
    assert tr.energy[-1] < 0.99 * tr.energy[0]
    with pytest.raises(ValueError, match="diagonal"):
        central_sparse(_disc_problem("consistent"), dt, 2, 1)


def test_sparse_explicit_quasistatic_contact_dofs():
    """redistributed[beta=0] on the disc: massless contact dofs solved from their rows
    (exact contact, complementarity with lambda = K U - F there), the rest explicit."""
    p = _disc_problem("redistributed")
    dt = 0.1 * p.hmin / p.c_max
    nsteps = int(0.6 / dt)
    tr = quasistatic_sparse(p, dt, nsteps, 1)
    assert tr.blowup_time is None and tr.extra["first_contact_start"] < 0.4
    gaps = p.gaps(tr.U[1:])  # from the first step on (U0 is data, not in equilibrium)
    assert gaps.min() >= -1e-12
    lam = (p.K @ tr.U[1:].T).T[:, p.contact.dofs] - p.F[p.contact.dofs]
    scale = np.abs(lam).max()
    assert lam.min() > -1e-9 * scale and np.abs(lam * gaps).max() < 1e-9 * scale * 0.05
    assert np.abs(tr.energy - tr.energy[0]).max() < 0.05 * abs(tr.energy[0])
    with pytest.raises(ValueError, match="massless"):
        quasistatic_sparse(_disc_problem("consistent"), dt, 2, 1)


# ------------------------------------------------------------------ the embedded bar

COLUMNS = ("err_u_linf_l2", "err_u_l2_h1", "err_v_l2_l2", "err_stress_l2",
           "energy_initial", "energy_final", "energy_drift_max", "penetration_max")
#: (T: a whole contact, dt). dropped_bar's free fall reaches the obstacle at t = 1 exactly,
#: a step of its default dt = 2e-3: whether u0 is -1e-13 or +8e-13 there (round-off)
#: decides the step of the impact (measured, taylor_flanagan): a dt off that tie
SCENES = {"clamped_bar": (2.5, None), "dropped_bar": (2.0, 2.1e-3), "rough_data": (2.0, None)}
#: the drift is relative already: 1e-9 of the energy. The error columns are errors
#: relative to the exact solution's norm: 1e-9 of them, or 1e-10 of that norm when the
#: error is small (dropped_bar: |u| = 5, error 0.008; the step at which a contact dof's
#: force reaches zero and it lifts off is decided on a round-off-sized force, which moves
#: u by about 1e-11 of its norm: 1.1e-9 of the error in 2D, 2.9e-9 in 3D, measured)
TOLERANCE = {"energy_drift_max": {"abs": 1e-9}, "penetration_max": {"rel": 1e-9, "abs": 1e-12}}
TOLERANCE.update({c: {"rel": 1e-9, "abs": 1e-10} for c in COLUMNS if c.startswith("err")})
SCHEMES = ("redistributed", "redistributed[variant=getfem]", "standard[mass=conservative]",
           "standard", "taylor_flanagan[mass=lumped]", "penalty", "nitsche[theta=1]",
           "nitsche[theta=0]", "nitsche[theta=-1]", "redistributed[beta=0]", "hht",
           "ode_verlet", "restitution", "moreau_jean",
           "penalty[beta=0]", "penalty[beta=0,mass=getfem]", "nitsche[beta=0,theta=1]",
           "nitsche[beta=0,theta=0]", "nitsche[beta=0,theta=-1]", "taylor_flanagan")


@pytest.mark.parametrize("dim", [2, 3])
@pytest.mark.parametrize("scene", list(SCENES))
def test_embedded_bar_reproduces_the_1d_row(scene, dim):
    (T, dt), nx = SCENES[scene], 16
    symmetric = 0
    for scheme in SCHEMES:
        a = run_one(scene, scheme, nx=nx, T=T, dt=dt).row
        b = run_one(f"embedded_bar[of={scene},dim={dim}]", scheme, nx=nx, T=T, dt=dt).row
        assert a["status"] == b["status"] == "ok", b["notes"]
        umax = float(np.max(np.abs(make_case(scene).u0(np.linspace(0, 1, 5))))) + 1.0
        if b["symmetry_defect"] > 1e-9 * umax:  # round-off split the active set: chatter
            assert scheme == "standard", scheme  # the massive contact node chatters
            continue
        symmetric += 1
        for col in COLUMNS:
            if a[col] is not None:
                tol = TOLERANCE.get(col, {"rel": 1e-9})
                assert b[col] == pytest.approx(a[col], **tol), (scheme, col)
        if a["penetration_max"] == 0.0:  # exact contact (penalty: compared above)
            assert b["penetration_max"] <= 1e-12
    assert symmetric >= len(SCHEMES) - 1  # every scheme but standard ran without chatter


def test_embedded_bar_sliding_sides_with_poisson_ratio():
    a = run_one("clamped_bar", "redistributed", nx=16, T=1.5).row
    b = run_one("embedded_bar[sides=sliding,nu=0.3]", "redistributed", nx=16, T=1.5).row
    assert b["symmetry_defect"] < 1e-9
    assert b["err_u_linf_l2"] == pytest.approx(a["err_u_linf_l2"], rel=1e-9)


class BandedOnly(Redistributed):
    """redistributed on the bar alone: a scheme with a 1D kernel only declares that it
    cannot run a body scene (`cannot_run`), and the harness reads that declaration."""

    name = "banded_only"

    def cannot_run(self, case) -> str | None:
        return "a 1D kernel only" if case.kind == "body" else None


@pytest.fixture
def banded_only(monkeypatch) -> str:
    monkeypatch.setitem(schemes().plugins, BandedOnly.name, BandedOnly)
    return BandedOnly.name


def test_a_scheme_that_declares_bars_only_is_not_applicable_on_bodies(banded_only):
    run = run_one("embedded_bar", banded_only, nx=8, T=0.1)
    assert run.row["status"] == "not applicable"
    assert "a 1D kernel only" in run.row["notes"]
    with pytest.raises(BenchError, match="a 1D kernel only"):
        run_one("embedded_bar", banded_only, nx=8, T=0.1, strict=True)
    assert run_one("clamped_bar", banded_only, nx=8, T=0.1).row["status"] == "ok"
    # the former examples of a sparse path's gaps run now (tests/test_sparse_explicit.py)
    for scheme in ("taylor_flanagan", "penalty[beta=0]", "nitsche[beta=0]"):
        assert run_one("embedded_bar", scheme, nx=8, T=0.1).row["status"] == "ok", scheme


def test_embedded_bar_refuses_bad_inner_scenes():
    with pytest.raises(BenchError, match="x-dependent"):
        make_case("embedded_bar[of=heterogeneous_bar]")
    with pytest.raises(BenchError):
        make_case("embedded_bar[of=nosuchbar]")


def test_list_shows_the_scene_kinds_and_what_cannot_run(capsys, banded_only):
    from contact_bench.cli.main import main

    assert main(["list"]) == 0
    lines = capsys.readouterr().out.splitlines()

    def block(name: str) -> str:
        i = next(k for k, line in enumerate(lines) if line.split()[:1] == [name])
        return "\n".join(lines[i:i + 4])

    assert "cannot run" not in block("standard")
    assert "cannot run" in block(banded_only) and "embedded_bar" in block(banded_only)
    assert "form=sparse" in block("embedded_bar")
