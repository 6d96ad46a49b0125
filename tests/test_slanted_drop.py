"""A plane at any angle through the gap operator: `slanted_drop` against `disc_drop` and
`sphere_drop`, every scheme.

With gravity turned with the plane the tilted scene is the untilted one in a rotated
frame: a scheme whose trajectory is a Lipschitz function of the data (massless contact
nodes, a penalty or Nitsche law, a velocity-level law) gives every observable of the
untilted run to 1e-9 relative. A scheme with exact contact on nodes that carry mass
(`Family.EXACT`) may switch a contact node on round-off and then chatter differently: its
free fall and first contact start are the same, the rest is reported (docs/contact.md).
With vertical gravity the momentum along the plane grows by exactly dt t.F per step,
impacts included (`err_plane_momentum`), for every scheme.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from contact_bench.api.plugin import Family
from contact_bench.api.registry import make_case, make_scheme, schemes
from contact_bench.harness import run_one

DISC = "disc_drop[degree=1,lift=5.1]"  # the impact at sqrt(102): not on a step
BALL = "sphere_drop[lift=0.1]"
#: (base scene, nx, T): the disc through its first contact, the ball through its impact
GRIDS = {DISC: (5, 12.0), BALL: (8, 2.0)}
#: variants whose steps differ from the defaults' (explicit paths, other laws)
VARIANTS = ("redistributed[beta=0]", "penalty[beta=0]", "nitsche[beta=0]",
            "taylor_flanagan[mass=lumped]", "restitution[e=0.5]", "moreau_jean[e=0.5]")
SCHEMES = tuple(schemes().names()) + VARIANTS


def _rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    if np.all(np.isnan(a)) and np.all(np.isnan(b)):
        return 0.0
    return float(np.max(np.abs(a - b)) / max(float(np.max(np.abs(a))), 1e-300))


def _lipschitz(spec: str) -> bool:
    """A run that a round-off change moves by round-off: not exact contact on nodes with
    mass, not an adaptive step, not a restitution coefficient acting on round-off gaps."""
    scheme = make_scheme(spec)
    return (scheme.traits().family != Family.EXACT and not spec.startswith("ode_adaptive")
            and not spec.startswith("restitution"))


@pytest.mark.parametrize("base", [DISC, BALL])
@pytest.mark.parametrize("spec", SCHEMES)
def test_tilted_with_gravity_is_the_untilted_scene_in_a_rotated_frame(spec, base):
    nx, T = GRIDS[base]
    tilted = f"slanted_drop[of={base},angle=30]"
    a, b = run_one(base, spec, nx=nx, T=T), run_one(tilted, spec, nx=nx, T=T)
    if a.trajectory is None:  # the scene refuses this scheme's mass: so does the tilted
        assert b.trajectory is None and b.row["status"] == a.row["status"]
        return
    ta, tb = a.trajectory, b.trajectory
    assert b.row["status"] == "ok" and a.row["status"] == "ok"
    dim = 2 if base == DISC else 3
    Q = sp.kron(sp.identity(tb.U.shape[1] // dim), make_case(tilted).rotation(dim))
    back = (Q.T @ tb.U.T).T  # the displacement turned back
    fall = ta.t < ta.extra["first_contact_start"] - 1e-12
    # free fall, every scheme (an adaptive one to its error control: the rotated state's
    # componentwise error norm takes other steps)
    rtol = getattr(make_scheme(spec), "rtol", 0.0) * 100
    assert _rel(ta.U[fall], back[fall]) <= max(1e-9, rtol)
    # the start is interpolated from the smallest gap, computed in each frame
    assert _rel(tb.extra["first_contact_start"], ta.extra["first_contact_start"]) <= max(
        1e-9, rtol)
    if not _lipschitz(spec):
        return
    for key in ("first_contact_end", "peak_contact_force", "contact_impulse", "chatter"):
        assert _rel(ta.extra[key], tb.extra[key]) <= 1e-9, key
    assert _rel(ta.energy, tb.energy) <= 1e-9
    assert _rel(ta.stress, tb.stress) <= 1e-9
    assert _rel(ta.U, back) <= 1e-9


@pytest.mark.parametrize("base", [DISC, BALL])
@pytest.mark.parametrize("spec", SCHEMES)
def test_momentum_along_a_frictionless_plane_grows_by_dt_times_the_load(spec, base):
    nx, T = GRIDS[base]
    run = run_one(f"slanted_drop[of={base},angle=30,tilt_gravity=0]", spec, nx=nx, T=T)
    if run.trajectory is None:
        assert run.row["status"] == "not applicable"
        return
    assert run.row["status"] == "ok" and run.trajectory.extra["peak_contact_force"] > 0
    assert run.row["err_plane_momentum"] <= 1e-9


def test_the_gap_operator_is_the_turned_normal_and_schemes_refuse_nothing():
    p = make_case(f"slanted_drop[of={DISC},angle=30]").sparse_problem(3, 1.0, "consistent")
    G = sp.csr_matrix(p.contact.gap_operator(p.nfree))
    rows = G.toarray().reshape(G.shape[0], -1, 2)
    normal = np.array([-np.sin(np.pi / 6), np.cos(np.pi / 6)])
    for r in rows:  # one node per row, the plane's unit normal on its two dofs
        (node,) = np.flatnonzero(np.any(r != 0, axis=1))
        assert np.allclose(r[node], normal, rtol=0, atol=1e-15)
    assert p.contact.dofs is None and p.contact.operator is not None


def test_a_scene_that_cannot_be_tilted_is_refused_in_one_line():
    from contact_bench.core.errors import BenchError

    with pytest.raises(BenchError, match="of = 'clamped_bar'"):
        make_case("slanted_drop[of=clamped_bar]")
