"""Node-to-facet rows (`contact_bench.api.node_to_facet`) on their own and in `two_balls`
with non-matching meshes: the projection against a sampled brute-force search of the
triangles, the weights summing to one and reproducing the projected point (and a
quadratic field, P2), a point inside a facet found in it, matching meshes giving the
node-to-node rows, the pair's momentum kept by every scheme that runs two bodies, and
the non-matching pair approaching its half problem as both meshes are refined."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import skfem as fe

from contact_bench.api import fem_nd
from contact_bench.api import node_to_facet as ntf
from contact_bench.api.fem import REDISTRIBUTED_KINDS, canonical_mass
from contact_bench.api.registry import make_case, make_scheme, schemes
from contact_bench.harness import run_one


def _ball(degree: int, nx: int, kind: str = "octahedron"):
    ball = make_case(f"sphere_drop[degree={degree},ball={kind}]")
    return ball, ball.body(nx)


def _lower(ball):
    return lambda x: x[2] < ball.centre_z + 0.5 * ball.R


def _node_positions(body, surf: ntf.TriangleSurface, f: int) -> np.ndarray:
    """(k, 3) where the facet's displacement nodes sit, from the body's own dof
    locations (not from the surface's geometry)."""
    return body.dof_coordinates[:, surf.dofs[f]].T


@pytest.mark.parametrize("degree", [1, 2])
def test_closest_point_projection_against_a_sampled_search(degree):
    ball, body = _ball(degree, 2)
    surf = ntf.surface(body, _lower(ball))
    rng = np.random.default_rng(3)
    u = rng.normal(size=(3, 30))
    u[2] = -np.abs(u[2])  # below the centre, 0 to 6 outside the ball
    u /= np.linalg.norm(u, axis=0)
    P = np.array([[0.0], [0.0], [ball.centre_z]]) + (ball.R + rng.uniform(0, 6, 30)) * u
    pr = ntf.project(P, surf)
    assert np.allclose(pr.weights.sum(axis=1), 1.0, rtol=0, atol=1e-14)
    g = np.linspace(0.0, 1.0, 121)  # barycentric samples of every triangle
    s, t = (x.ravel() for x in np.meshgrid(g, g))
    keep = s + t <= 1.0
    lam = np.stack([1 - s[keep] - t[keep], s[keep], t[keep]], axis=1)
    samples = np.einsum("sv,fvc->fsc", lam, surf.geometry).reshape(-1, 3)
    h = max(np.linalg.norm(surf.geometry[:, 1] - surf.geometry[:, 0], axis=1)) / 120
    for j in range(P.shape[1]):
        dist = np.linalg.norm(pr.point[j] - P[:, j])
        brute = np.min(np.linalg.norm(samples - P[:, j], axis=1))
        assert dist <= brute + 1e-12 and brute - dist <= h  # the samples' resolution
        assert abs(pr.gap0[j] - dist) <= 1e-9 * ball.R  # outside: the distance
        n = pr.normal[j]
        assert abs(np.linalg.norm(n) - 1.0) <= 1e-14
        assert n @ (pr.point[j] - [0.0, 0.0, ball.centre_z]) > 0  # outward
        # the weights reproduce the projected point from the nodes' own positions
        X = _node_positions(body, surf, pr.facet[j])
        assert np.allclose(pr.weights[j] @ X, pr.point[j], rtol=0, atol=1e-12)


@pytest.mark.parametrize("degree", [1, 2])
def test_a_point_inside_a_facet_is_found_in_it(degree):
    ball, body = _ball(degree, 4)
    surf = ntf.surface(body, _lower(ball))
    normals = surf.normals()
    rng = np.random.default_rng(11)
    for f in rng.choice(surf.geometry.shape[0], 12, replace=False):
        lam = rng.dirichlet([2.0, 2.0, 2.0])  # well inside
        inner = lam @ surf.geometry[f]
        h = 0.01 * ball.R / 4  # just outside, along the facet's normal
        p = inner + h * normals[f]
        pr = ntf.project(p[:, None], surf)
        assert pr.facet[0] == f
        assert np.allclose(pr.xi[0], lam, rtol=0, atol=1e-12)
        assert np.allclose(pr.point[0], inner, rtol=0, atol=1e-12)
        assert abs(pr.gap0[0] - h) <= 1e-12
        # along -normal from further out: the same facet and point
        pa = ntf.project((inner + 5 * h * normals[f])[:, None], surf, normal=normals[f])
        assert pa.facet[0] == f and np.allclose(pa.point[0], inner, rtol=0, atol=1e-12)
        assert abs(pa.gap0[0] - 5 * h) <= 1e-12
        # a quadratic field is interpolated exactly on the flat triangle (P2), a linear
        # one on either degree: the weights are the element's shape functions
        X = _node_positions(body, surf, f)
        fields = [lambda x: x @ [1.0, -2.0, 0.5]]
        if degree == 2:
            fields.append(lambda x: np.sum(x * x, axis=-1))
        for field in fields:
            assert abs(pr.weights[0] @ field(X) - field(inner[None])[0]) <= 1e-9


def test_projection_along_a_direction_lands_on_the_line():
    ball, body = _ball(1, 4)
    surf = ntf.surface(body, _lower(ball))
    xy = np.random.default_rng(5).uniform(-12.0, 12.0, (2, 25))
    P = np.vstack([xy, np.full(25, -3.0)])  # below the ball, projected upwards
    d = np.array([0.0, 0.0, -1.0])  # the rows' normal: from the master to the points
    pr = ntf.project(P, surf, normal=d)
    assert np.allclose(pr.weights.sum(axis=1), 1.0, rtol=0, atol=1e-14)
    assert np.allclose(pr.point[:, :2], xy.T, rtol=0, atol=1e-12)  # straight above
    r = np.linalg.norm(pr.point - [0.0, 0.0, ball.centre_z], axis=1)
    assert np.all(r <= ball.R + 1e-9) and np.all(r >= 0.9 * ball.R)  # on the flat faces
    assert np.allclose(pr.gap0, pr.point[:, 2] + 3.0, rtol=0, atol=1e-12)


def test_rows_spread_the_normal_with_the_weights():
    mesh = fe.MeshTet1.init_tensor(np.linspace(0.0, 2.0, 3), np.linspace(0.0, 1.0, 2),
                                   np.linspace(-1.0, 0.0, 2))
    body = fem_nd.assemble(mesh, 1.0, 0.3, 1.0)
    surf = ntf.surface(body, lambda x: x[2] > -1e-9)  # the top z = 0
    P = np.array([[0.25, 1.5, 2.0], [0.5, 0.25, 1.0], [0.5, 0.25, 0.0]])
    pr = ntf.project(P, surf)
    assert np.allclose(pr.normal, [[0.0, 0.0, 1.0]] * 3) and np.allclose(pr.gap0, P[2])
    G = ntf.gap_rows(pr, np.array([1, 4, 6]), surf, 30, body.ndofs).toarray()
    want = np.zeros_like(G)
    want[:, [5, 14, 20]] = np.eye(3)  # +1 on each slave node's z dof
    X = body.dof_coordinates
    for i in range(3):  # -N_k on the z dofs of the triangle under the point, by hand:
        verts = X[:, surf.dofs[pr.facet[i]]]  # the plane coordinates of its vertices
        A = np.vstack([verts[:2], np.ones(3)])
        lam = np.linalg.solve(A, [P[0, i], P[1, i], 1.0])
        want[i, 30 + 3 * surf.dofs[pr.facet[i]] + 2] -= lam
    assert np.allclose(G, want, rtol=0, atol=1e-15)


@pytest.mark.parametrize("kind", ["octahedron", "lattice"])
@pytest.mark.parametrize("degree", [1, 2])
def test_matching_meshes_give_the_node_to_node_rows(degree, kind):
    """Each zone node of A paired by hand with its mirror image on B (the same scalar
    dof of B's copy of the mesh): the same G and twice the half problem's gaps."""
    nx = 2 if kind == "octahedron" else 3
    spec = f"two_balls[degree={degree},ball={kind}]"
    one = make_case(f"{spec[:-1]},half=1]").sparse_problem(nx, 1.0, "consistent")
    p = make_case(spec).sparse_problem(nx, 1.0, "consistent")
    n, c = one.nfree, one.contact
    dofs = np.asarray(c.dofs, np.int64)
    rows = np.arange(dofs.size)
    want = sp.csr_matrix((np.r_[np.ones(dofs.size), -np.ones(dofs.size)],
                          (np.r_[rows, rows], np.r_[dofs, n + dofs])), shape=(dofs.size, 2 * n))
    G = sp.csr_matrix(p.contact.gap_operator(p.nfree))
    assert G.shape == want.shape
    assert abs(G - want).max() <= 1e-14
    assert np.max(np.abs(p.contact.gap0 - 2.0 * np.asarray(c.gap0))) <= 1e-14 * 40.0
    assert np.allclose(p.gaps(p.U0), 2 * one.gaps(p.U0[:n]), rtol=0, atol=1e-12)


@pytest.mark.parametrize("spec", ["two_balls[turn_b=7]", "two_balls[ball_b=lattice]",
                                  "two_balls[degree=2,turn_b=7]"])
def test_non_matching_rows_carry_no_net_force(spec):
    p = make_case(spec).sparse_problem(4, 1.0, "consistent")
    G = sp.csr_matrix(p.contact.gap_operator(p.nfree))
    for c in range(3):
        x = (np.arange(p.nfree) % 3 == c).astype(float)
        assert np.max(np.abs(G @ x)) <= 1e-15
    assert np.count_nonzero(np.diff(G.indptr) > 2) > 0  # rows spread over a facet
    assert np.min(p.gaps(p.U0)) >= 0.0


TWO = "two_balls[lift=0.505,turn_b=7]"


def grid(spec: str) -> tuple[int, float]:
    """(nx, T): the ball through the contact of its first ring of nodes off the pole
    (the rows spread over B's facets): at nx 4, or at nx 8 for a scheme with the
    redistributed mass (not positive definite on the ball below nx 8)."""
    if canonical_mass(make_scheme(spec).mass_kind()) in REDISTRIBUTED_KINDS:
        return 8, 1.5
    return 4, 3.0


@pytest.mark.parametrize("spec", tuple(schemes().names()) + ("penalty[beta=0]",
                                                             "moreau_jean[e=0.5]"))
def test_the_pair_keeps_its_momentum_on_non_matching_meshes(spec):
    """Without gravity G^T lambda sums to zero along x, y and z (each row's weights sum
    to one): the pair's momentum 1_c . M V is kept at every sample, impacts included."""
    nx, T = grid(spec)
    run = run_one(TWO, spec, nx=nx, T=T)
    if make_case(TWO).cannot_run(make_scheme(spec)) is not None or run.trajectory is None:
        assert run.row["status"] == "not applicable"
        return
    assert run.row["status"] == "ok"
    assert run.trajectory.extra["contact_impulse"] > 0.0  # the balls met
    assert run.row["err_pair_momentum"] <= 1e-11


def test_bad_inputs_are_named_in_one_line():
    ball, body = _ball(1, 2)
    surf = ntf.surface(body, _lower(ball))
    with pytest.raises(ValueError, match=r"direction \[0.0, 0.0, 0.0\]"):
        ntf.project(np.zeros((3, 1)), surf, normal=[0.0, 0.0, 0.0])
    with pytest.raises(ValueError, match="slave point 0 at"):
        ntf.project(np.array([[100.0], [0.0], [-5.0]]), surf, normal=[0.0, 0.0, -1.0])
    with pytest.raises(ValueError, match=r"points of shape \(2, 1\)"):
        ntf.project(np.zeros((2, 1)), surf)
    with pytest.raises(ValueError, match="built in 3D; got a 2D body"):
        mesh = fe.MeshTri1.init_tensor(*(np.linspace(0, 1, 2),) * 2)
        ntf.surface(fem_nd.assemble(mesh, 1.0, 0.3, 1.0), lambda x: x[1] > 0.5)
    with pytest.raises(ValueError, match="no boundary facet"):
        ntf.surface(body, lambda x: x[2] > 1e6)
    with pytest.raises(ValueError, match="5 nodes"):
        ntf.shape(5, np.zeros((1, 3)))
