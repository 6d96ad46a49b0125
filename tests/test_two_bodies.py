"""The two-body scenes' shared refusal and momentum check (contact_bench.api.two_bodies)."""

from types import SimpleNamespace

import numpy as np
import pytest
import scipy.sparse as sp

from contact_bench.api import make_case, make_scheme, two_bodies


@pytest.mark.parametrize("name", ["two_discs", "two_balls"])
def test_nitsche_is_refused_between_two_bodies_and_pointed_to_half(name):
    reason = make_case(name).cannot_run(make_scheme("nitsche"))
    assert reason is not None and f"{name}[half=1]" in reason
    assert two_bodies.nitsche_refusal(make_case(f"{name}[half=1]"), make_scheme("nitsche")) is None
    assert two_bodies.nitsche_refusal(make_case(name), make_scheme("standard")) is None


def test_pair_momentum_error_is_the_largest_drift_per_direction():
    # 2D, two nodes: dofs (x0, y0, x1, y1), masses 1, 2, 3, 4; by hand:
    # p_x = V0 + 3 V2 = 4, 4, 5.5 (drift 1.5); p_y = 2 V1 + 4 V3 = 0, -2, 0 (drift 2)
    problem = SimpleNamespace(nfree=4, dim=2, M=sp.diags([1.0, 2.0, 3.0, 4.0]),
                              body_mass=10.0)
    V = np.array([[1.0, 0.0, 1.0, 0.0], [1.0, -1.0, 1.0, 0.0], [2.5, 0.0, 1.0, 0.0]])
    scene = SimpleNamespace(half=0, speed=0.5)
    err = two_bodies.pair_momentum_errors(scene, problem, SimpleNamespace(V=V))
    assert err == {"err_pair_momentum": pytest.approx(2.0 / (10.0 * 0.5))}
    assert two_bodies.pair_momentum_errors(SimpleNamespace(half=1, speed=0.5), problem,
                                           SimpleNamespace(V=V)) == {}
