"""A large body's assembly in bounded memory: K and the scalar mass summed over chunks of
elements equal scikit-fem's whole-mesh assembly (to round-off), and the contact zone's
stress projection solved a block of columns at a time keeps the same entries as the
dense solve. The thresholds are lowered so that a small mesh takes the large path."""

from __future__ import annotations

import numpy as np
import pytest
import skfem as fe

from contact_bench.api import fem_nd


@pytest.mark.parametrize("degree", [1, 2])
def test_chunked_assembly_is_the_whole_mesh_one(monkeypatch, degree):
    mesh = fe.MeshTet.init_ball(2)  # 512 tetrahedra
    whole = fem_nd.assemble(mesh, 3.0, 0.3, 2.0, degree=degree)
    monkeypatch.setattr(fem_nd, "ASSEMBLY_CHUNK_ABOVE", 100)
    monkeypatch.setattr(fem_nd, "CHUNK_ELEMENTS", 77)  # 7 chunks, the last one short
    chunked = fem_nd.assemble(mesh, 3.0, 0.3, 2.0, degree=degree)
    assert chunked.K.shape == whole.K.shape and chunked.Ms.shape == whole.Ms.shape
    assert abs(chunked.K - whole.K).max() <= 1e-14 * abs(whole.K).max()
    assert abs(chunked.Ms - whole.Ms).max() <= 1e-14 * abs(whole.Ms).max()
    # the kept bases cover one element but the mesh's dofs and their places
    assert chunked.vector.nelems == 1 and chunked.ndofs == whole.ndofs
    np.testing.assert_array_equal(chunked.dof_coordinates, whole.dof_coordinates)
    # independent of the assembly: K annihilates rigid translations, Ms sums to the mass
    assert abs(chunked.K @ np.tile([1.0, 0.0, 0.0], chunked.ndofs // 3)).max() < 1e-10
    volume = np.sum(np.abs(np.linalg.det(
        np.stack([mesh.p[:, mesh.t[i]] - mesh.p[:, mesh.t[0]] for i in (1, 2, 3)],
                 axis=-1).transpose(1, 0, 2)))) / 6.0
    assert chunked.Ms.sum() == pytest.approx(2.0 * volume, rel=1e-12)


def test_blocked_zone_projection_keeps_the_dense_entries(monkeypatch):
    body = fem_nd.assemble(fe.MeshTet.init_ball(2), 1.0, 0.3, 1.0)
    facets = body.boundary_facets(lambda x: x[2] < -0.01)
    dense = fem_nd.contact_zone(body, facets, axis=2, plane=-1.0)
    shear = fem_nd.contact_shear(body, facets, 2, 0)
    monkeypatch.setattr(fem_nd, "ZONE_DENSE_ENTRIES", 10)
    monkeypatch.setattr(fem_nd, "ZONE_BLOCK", 13)
    blocked = fem_nd.contact_zone(body, facets, axis=2, plane=-1.0)
    assert blocked.normal_stress.nnz == dense.normal_stress.nnz
    assert abs(blocked.normal_stress - dense.normal_stress).max() == 0.0
    assert abs(fem_nd.contact_shear(body, facets, 2, 0) - shear).max() == 0.0
    # a uniform compression u_z = -z: sigma_zz = -(lambda + 2 mu) at every zone dof
    lam, mu = body.lam, body.mu
    u = np.zeros(body.ndofs)
    u[2::3] = -body.dof_coordinates[2]
    np.testing.assert_allclose(blocked.normal_stress @ u, -(lam + 2 * mu), rtol=1e-10)
