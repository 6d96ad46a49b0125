"""Scenes derived from a base scene (`contact_bench.api.derived.DerivedScene`:
curved_drop, slanted_drop): what is the body's is the base's, a bad base is refused in one
line, and friction on a curved obstacle is refused (the frictional steppers keep their
normal and tangent rows fixed), at the scene and at the stepper."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.sparse as sp

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core.errors import BenchError

DERIVED = ("curved_drop", "curved_drop[of=disc_drop[degree=1],R_o=20]",
           "curved_drop[of=sphere_drop]", "slanted_drop", "slanted_drop[of=sphere_drop]")


@pytest.mark.parametrize("spec", DERIVED)
def test_what_is_the_body_s_is_the_base_s(spec):
    case = make_case(spec)
    base = make_case(case.of)
    assert case.base.spec == base.spec
    assert (case.size, case.exact_energy) == (base.size, base.exact_energy)
    # hertz_sphere declares no impact time: neither does a scene derived from it
    assert getattr(case, "impact_time", None) == getattr(base, "impact_time", None)
    assert (case.nx, case.dt, case.stride) == (base.nx, base.dt, base.stride)
    assert case.footprint(2) == base.footprint(2)
    assert case.friction() == base.friction() == 0.0


@pytest.mark.parametrize("name", ["curved_drop", "slanted_drop"])
def test_a_base_that_cannot_be_derived_is_refused_in_one_line(name):
    with pytest.raises(BenchError, match=r"of = 'clamped_bar': allowed scenes") as exc:
        make_case(f"{name}[of=clamped_bar]")
    assert "\n" not in str(exc.value)


def _with_friction(mu: float):
    """The disc over a circle of radius 20 (2D, P1, nx 3), each contact point given its
    unit tangent at the reference and Coulomb's mu."""
    p = make_case("curved_drop[of=disc_drop[degree=1],R_o=20]").sparse_problem(
        3, 1.0, "consistent")
    c = p.contact
    ob = c.obstacle
    n = (ob.points - ob.centre) / np.linalg.norm(ob.points - ob.centre, axis=1)[:, None]
    rows, cols, vals = [], [], []
    for j in range(c.size):
        for a, t in enumerate((-n[j, 1], n[j, 0])):
            if ob.dofs[j, a] >= 0:
                rows.append(j)
                cols.append(ob.dofs[j, a])
                vals.append(t)
    T = sp.csr_matrix((vals, (rows, cols)), shape=(c.size, p.nfree))
    contact = dataclasses.replace(c, tangents=T, friction=np.full(c.size, mu))
    return dataclasses.replace(p, contact=contact)


@pytest.mark.parametrize("spec", ["moreau_jean", "standard", "redistributed", "penalty"])
def test_friction_on_a_curved_obstacle_is_refused_by_the_stepper(spec):
    """Each frictional scheme (Traits.friction) refuses, naming mu and the obstacle; with
    mu = 0 the same contact set is the frictionless one and runs."""
    scheme = make_scheme(spec)
    assert scheme.traits().friction
    with pytest.raises(ValueError, match=r"friction \(mu = 0\.3\) on a curved obstacle "
                                         r"\(a sphere of radius 20\)") as exc:
        scheme.prepare(_with_friction(0.3), 0.01)
    assert "\n" not in str(exc.value)
    tr = scheme.prepare(_with_friction(0.0), 0.01).run(3, 1)
    assert np.all(np.isfinite(tr.U))


def test_friction_on_a_curved_obstacle_is_not_applicable_at_the_scene(monkeypatch):
    case = make_case("curved_drop[of=disc_drop[degree=1],R_o=20]")
    scheme = make_scheme("moreau_jean")
    assert case.cannot_run(scheme) is None
    monkeypatch.setattr(case.base, "friction", lambda: 0.3)
    reason = case.cannot_run(scheme)
    assert reason is not None and "mu = 0.3" in reason and "R_o = 20" in reason
