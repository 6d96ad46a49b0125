"""A body's assembly in bounded memory: K and the scalar mass summed over chunks of
elements equal scikit-fem's whole-mesh assembly of its own elasticity and mass forms
(to round-off), the temporaries stay near the chunk budget, and the contact zone's
stress projection solved a block of columns at a time keeps the same entries as the
dense solve. The sizes are lowered so that a small mesh takes several chunks."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest
import skfem as fe
from skfem.models.elasticity import linear_elasticity
from skfem.models.poisson import mass

from contact_bench.api import fem_nd


def _skfem_whole(mesh: fe.Mesh, E: float, nu: float, rho: float, degree: int):
    """K and the scalar mass by scikit-fem alone over the whole mesh: its own forms,
    Lame's constants from E and nu written out here."""
    lam, mu = E * nu / ((1 + nu) * (1 - 2 * nu)), E / (2 * (1 + nu))
    elem = {1: fe.ElementTetP1, 2: fe.ElementTetP2}[degree]()
    scalar = fe.Basis(mesh, elem)
    vector = fe.Basis(mesh, fe.ElementVector(elem), quadrature=scalar.quadrature)
    return (linear_elasticity(lam, mu).assemble(vector),
            rho * mass.assemble(scalar))


@pytest.mark.parametrize("degree", [1, 2])
def test_chunked_assembly_is_the_whole_mesh_one(monkeypatch, degree):
    mesh = fe.MeshTet.init_ball(2)  # 512 tetrahedra
    K, Ms = _skfem_whole(mesh, 3.0, 0.3, 2.0, degree)
    one = fem_nd.assemble(mesh, 3.0, 0.3, 2.0, degree=degree)  # one chunk at this size
    monkeypatch.setattr(fem_nd, "chunk_elements", lambda basis: 77)  # 7, the last short
    chunked = fem_nd.assemble(mesh, 3.0, 0.3, 2.0, degree=degree)
    for body in (one, chunked):
        assert body.K.shape == K.shape and body.Ms.shape == Ms.shape
        assert abs(body.K - K).max() <= 1e-14 * abs(K).max()
        assert abs(body.Ms - Ms).max() <= 1e-14 * abs(Ms).max()
        # the kept bases cover one element but the mesh's dofs and their places
        assert body.vector.nelems == 1 and body.ndofs == K.shape[0]
        whole = fe.Basis(mesh, body.scalar.elem)
        np.testing.assert_array_equal(body.dof_coordinates, whole.doflocs)
        # a form over the body goes through its full basis: the whole mesh's volume
        volume = fe.Functional(lambda w: 1.0 + 0.0 * w.x[0]).assemble(body.full_basis())
        assert volume == pytest.approx(Ms.sum() / 2.0, rel=1e-12)
    # independent of the assembly: K annihilates rigid translations, Ms sums to the mass
    assert abs(chunked.K @ np.tile([1.0, 0.0, 0.0], chunked.ndofs // 3)).max() < 1e-10
    volume = np.sum(np.abs(np.linalg.det(
        np.stack([mesh.p[:, mesh.t[i]] - mesh.p[:, mesh.t[0]] for i in (1, 2, 3)],
                 axis=-1).transpose(1, 0, 2)))) / 6.0
    assert chunked.Ms.sum() == pytest.approx(2.0 * volume, rel=1e-12)


def test_assembly_temporaries_stay_near_the_chunk_budget(monkeypatch):
    """The Python-side allocations of an assembly in chunks stay below the finished
    matrices plus a few chunk budgets (the whole mesh's temporaries are ten times
    more); `chunk_elements`' estimate is within a factor of two of a chunk's own peak."""
    mesh = fe.MeshTet.init_ball(3)  # 4,096 tetrahedra
    budget = 2**21
    monkeypatch.setattr(fem_nd, "ASSEMBLY_CHUNK_BYTES", budget)
    tracemalloc.start()
    try:
        body = fem_nd.assemble(mesh, 1.0, 0.3, 1.0)
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    kept = sum(m.data.nbytes + m.indices.nbytes + m.indptr.nbytes for m in (body.K, body.Ms))
    step = fem_nd.chunk_elements(body.vector)
    assert 5 <= mesh.nelements / step <= 40  # several chunks
    assert peak <= 2 * kept + 3 * budget
    # one chunk alone: its measured temporaries against the estimate
    part = np.arange(step)
    tracemalloc.start()
    try:
        fem_nd._stiffness.assemble(fe.CellBasis(
            mesh, body.vector.elem, elements=part, quadrature=body.scalar.quadrature,
            dofs=body.vector.dofs, disable_doflocs=True), lam=1.0, mu=1.0).tocsr()
        chunk = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert budget / 2 <= chunk <= 2 * budget


def test_blocked_zone_projection_keeps_the_dense_entries(monkeypatch):
    body = fem_nd.assemble(fe.MeshTet.init_ball(2), 1.0, 0.3, 1.0)
    facets = body.boundary_facets(lambda x: x[2] < -0.01)
    dense = fem_nd.contact_zone(body, facets, axis=2, plane=-1.0)
    shear = fem_nd.contact_shear(body, facets, 2, 0)
    nc = dense.scalar.size
    monkeypatch.setattr(fem_nd, "ZONE_BLOCK_ENTRIES", 13 * nc)  # 13 columns a block
    blocked = fem_nd.contact_zone(body, facets, axis=2, plane=-1.0)
    assert blocked.normal_stress.nnz == dense.normal_stress.nnz
    assert abs(blocked.normal_stress - dense.normal_stress).max() == 0.0
    assert abs(fem_nd.contact_shear(body, facets, 2, 0) - shear).max() == 0.0
    # a uniform compression u_z = -z: sigma_zz = -(lambda + 2 mu) at every zone dof
    lam, mu = body.lam, body.mu
    u = np.zeros(body.ndofs)
    u[2::3] = -body.dof_coordinates[2]
    np.testing.assert_allclose(blocked.normal_stress @ u, -(lam + 2 * mu), rtol=1e-10)
