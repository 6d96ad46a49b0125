"""Node-to-segment rows (`contact_bench.api.node_to_segment`) on their own and in
`two_discs` with non-matching meshes: the projection against a brute-force search of the
facets, the weights summing to one, matching meshes giving the node-to-node rows bit for
bit, the pair's momentum kept by every scheme that runs two bodies, and the non-matching
pair approaching its half problem as both meshes are refined."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
import skfem as fe

from contact_bench.api import fem_nd
from contact_bench.api import node_to_segment as nts
from contact_bench.api.registry import make_case, make_scheme, schemes
from contact_bench.harness import run_one

MIRROR = np.array([[1.0], [-1.0]])


def _disc(degree: int, nx: int):
    disc = make_case(f"disc_drop[degree={degree}]")
    body = disc.body(nx)
    problem = disc.sparse_problem(nx, 1.0, "consistent")
    return disc, body, problem


def _curve(geometry: np.ndarray, xi: np.ndarray) -> np.ndarray:
    """Points of a facet's curve at xi, by np.polyfit through its nodes (an
    interpolation independent of `nts.shape`)."""
    at = np.array([0.0, 1.0, 0.5])[:geometry.shape[0]]
    deg = geometry.shape[0] - 1
    return np.stack([np.polyval(np.polyfit(at, geometry[:, c], deg), xi) for c in (0, 1)],
                    axis=1)


@pytest.mark.parametrize("degree", [1, 2])
def test_closest_point_projection_against_a_brute_force_search(degree):
    disc, body, _ = _disc(degree, 3)
    surf = nts.surface(body, lambda x: x[1] < disc.centre_y + 0.5 * disc.R)
    rng = np.random.default_rng(7)
    a = rng.uniform(-np.pi, 0.0, 40)  # points below the disc, 0 to 8 away from it
    r = disc.R + rng.uniform(0.0, 8.0, 40)
    P = np.vstack([r * np.cos(a), disc.centre_y + r * np.sin(a)])
    pr = nts.project(P, surf)
    assert np.allclose(pr.weights.sum(axis=1), 1.0, rtol=0, atol=1e-15)
    xi = np.linspace(0.0, 1.0, 20001)
    for s in range(P.shape[1]):
        dist = np.linalg.norm(pr.point[s] - P[:, s])
        brute = min(np.min(np.linalg.norm(_curve(g, xi) - P[:, s], axis=1))
                    for g in surf.geometry)
        assert abs(dist - brute) <= 1e-6  # the sampled curve's resolution
        g = surf.geometry[pr.facet[s]]
        assert np.allclose(_curve(g, pr.xi[s:s + 1])[0], pr.point[s], rtol=0, atol=1e-12)
        n = pr.normal[s]
        assert abs(np.linalg.norm(n) - 1.0) <= 1e-14
        assert n @ (pr.point[s] - [0.0, disc.centre_y]) > 0  # outward
        assert abs(pr.gap0[s] - dist) <= 1e-9  # outside the disc: the distance
        if degree == 2:  # the displacement nodes are the geometry's: they give the point
            assert np.allclose(pr.weights[s] @ g, pr.point[s], rtol=0, atol=1e-12)


@pytest.mark.parametrize("degree", [1, 2])
def test_projection_along_a_direction_lands_on_the_line(degree):
    disc, body, _ = _disc(degree, 3)
    surf = nts.surface(body, lambda x: x[1] < disc.centre_y + 0.5 * disc.R)
    x = np.linspace(-19.0, 19.0, 23)
    P = np.vstack([x, np.full_like(x, -3.0)])  # below the disc, projected upwards
    d = np.array([0.0, -1.0])  # the rows' normal: from the master towards the points
    pr = nts.project(P, surf, normal=d)
    assert np.allclose(pr.weights.sum(axis=1), 1.0, rtol=0, atol=1e-15)
    assert np.allclose(pr.point[:, 0], x, rtol=0, atol=1e-12)  # straight above
    # on the circle to the geometry's accuracy, and the gap the vertical distance
    r = np.hypot(pr.point[:, 0], pr.point[:, 1] - disc.centre_y)
    assert np.max(np.abs(r - disc.R)) <= 0.05
    assert np.allclose(pr.gap0, pr.point[:, 1] + 3.0, rtol=0, atol=1e-12)


def test_rows_spread_the_normal_with_the_weights():
    mesh = fe.MeshTri1.init_tensor(np.linspace(0.0, 3.0, 4), np.linspace(-1.0, 0.0, 2))
    body = fem_nd.assemble(mesh, 1.0, 0.3, 1.0)
    surf = nts.surface(body, lambda x: x[1] > -1e-9)  # the top y = 0
    P = np.array([[0.25, 1.5, 3.0], [0.5, 0.25, 0.0]])  # a slave body's three nodes
    pr = nts.project(P, surf)
    assert np.allclose(pr.normal, [[0.0, 1.0]] * 3) and np.allclose(pr.gap0, P[1])
    G = nts.gap_rows(pr, np.array([4, 7, 9]), surf, 20, body.ndofs).toarray()
    node = {round(float(X), 9): s for s, X in enumerate(body.dof_coordinates[0])
            if body.dof_coordinates[1, s] == 0.0}
    want = np.zeros_like(G)
    want[:, [9, 15, 19]] = np.eye(3)  # +1 on each slave node's y dof
    for i, (left, right, w) in enumerate([(0.0, 1.0, 0.75), (1.0, 2.0, 0.5),
                                          (2.0, 3.0, 0.0)]):
        want[i, 20 + 2 * node[left] + 1] -= w
        want[i, 20 + 2 * node[right] + 1] -= 1.0 - w
    assert np.allclose(G, want, rtol=0, atol=1e-15)


@pytest.mark.parametrize("degree", [1, 2])
@pytest.mark.parametrize("nx", [2, 3])
def test_matching_meshes_give_the_node_to_node_rows_bit_for_bit(degree, nx):
    """The mirror pairing of each zone node built by hand (as two_discs did before its
    rows were projected): the same G, the same gaps, to the bit."""
    _, _, one = _disc(degree, nx)
    p = make_case(f"two_discs[degree={degree}]").sparse_problem(nx, 1.0, "consistent")
    n, c = one.nfree, one.contact
    dofs = np.asarray(c.dofs, np.int64)
    rows = np.arange(dofs.size)
    want = sp.csr_matrix((np.r_[np.ones(dofs.size), -np.ones(dofs.size)],
                          (np.r_[rows, rows], np.r_[dofs, n + dofs])), shape=(dofs.size, 2 * n))
    G = p.contact.gap_operator(p.nfree)
    assert G.shape == want.shape and (G != want).nnz == 0
    assert np.array_equal(G.indptr, want.indptr) and np.array_equal(G.indices, want.indices)
    assert np.array_equal(G.data, want.data)
    assert np.array_equal(p.contact.gap0, 2.0 * np.asarray(c.gap0))


@pytest.mark.parametrize("spec", ["two_discs[rings_b=1]", "two_discs[turn_b=7]",
                                  "two_discs[degree=2,rings_b=1]",
                                  "two_discs[degree=2,turn_b=7]"])
def test_non_matching_rows_carry_no_net_force(spec):
    p = make_case(spec).sparse_problem(3, 1.0, "consistent")
    G = p.contact.gap_operator(p.nfree)
    n_a = make_case("disc_drop[degree=1]").sparse_problem(3, 1.0, "consistent").nfree
    assert G.shape[1] > 2 * n_a or "turn_b" in spec
    x = (np.arange(p.nfree) % 2 == 0).astype(float)
    assert np.max(np.abs(G @ x)) == 0.0 and np.max(np.abs(G @ (1.0 - x))) <= 1e-15
    assert np.count_nonzero(np.diff(G.indptr) > 2) > 0  # rows spread over a facet
    assert np.min(p.gaps(p.U0)) >= 0.0


TWO = "two_discs[lift=0.505,turn_b=7]"


@pytest.mark.parametrize("spec", tuple(schemes().names()) + ("penalty[beta=0]",
                                                             "moreau_jean[e=0.5]"))
def test_the_pair_keeps_its_momentum_on_non_matching_meshes(spec):
    """Without gravity G^T lambda sums to zero along x and y (each row's weights sum to
    one): the pair's momentum 1_c . M V is kept at every sample, impacts included."""
    run = run_one(TWO, spec, nx=3, T=1.5)
    if make_case(TWO).cannot_run(make_scheme(spec)) is not None or run.trajectory is None:
        assert run.row["status"] == "not applicable"
        return
    assert run.row["status"] == "ok"
    assert run.trajectory.extra["contact_impulse"] > 0.0  # the discs met
    assert run.row["err_pair_momentum"] <= 1e-11


def test_non_matching_pair_approaches_its_half_problem_as_both_are_refined():
    """The continuous pair is symmetric, so the non-matching one differs from the half
    problem by its discretisation error: at nx 3 and 6 (benchmarks/node_to_segment.py
    prints more) disc A's displacement differs by 0.163 and 0.041, the first contact's
    impulse by 0.068 and 0.020. Bound: halved at least when h halves (an order above one
    half; the contact observables of disc_drop converge at about one)."""
    diffs = {}
    for nx in (3, 6):
        half = run_one("two_discs[lift=0.505,half=1]", "redistributed", nx=nx, T=3.0)
        two = run_one(TWO, "redistributed", nx=nx, T=3.0)
        a, b = half.trajectory, two.trajectory
        n = a.U.shape[1]
        du = np.max(np.abs(a.U - b.U[:, :n])) / np.max(np.abs(a.U))
        key = "contact_impulse"
        di = abs(a.extra[key] - b.extra[key]) / abs(a.extra[key])
        diffs[nx] = (du, di)
    assert diffs[6][0] <= 0.5 * diffs[3][0] and diffs[6][1] <= 0.5 * diffs[3][1]
    assert diffs[6][0] <= 0.06


def test_bad_inputs_are_named_in_one_line():
    disc, body, _ = _disc(1, 2)
    surf = nts.surface(body, lambda x: x[1] < disc.centre_y)
    with pytest.raises(ValueError, match=r"direction \[0.0, 0.0\]"):
        nts.project(np.zeros((2, 1)), surf, normal=[0.0, 0.0])
    with pytest.raises(ValueError, match="slave point 0 at"):
        nts.project(np.array([[100.0], [-5.0]]), surf, normal=[0.0, -1.0])
    with pytest.raises(ValueError, match="built in 2D; got a 3D body"):
        mesh = fe.MeshTet1.init_tensor(*(np.linspace(0, 1, 2),) * 3)
        nts.surface(fem_nd.assemble(mesh, 1.0, 0.3, 1.0), lambda x: x[2] > 0.5)
    with pytest.raises(ValueError, match="4 nodes"):
        nts.shape(4, np.zeros(1))
