"""The contact as a gap operator: gaps = gap0 + G U with G a sparse n_c x n operator.

A plane normal to a coordinate axis makes G a selection of dofs (`ContactSet.dofs`); a
general G (`ContactSet.operator`, a slanted or curved obstacle) fits the same contract:
the problem checks its shape, gives its gaps, and both a scheme written on
`gap_operator` (the docs' plain-numpy template) and the compiled kernels run it
(`contact_bench.kernels.contact`): the template and the compiled lumped Taylor-Flanagan
give the same slanted run.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import re
from pathlib import Path

import numpy as np
import pytest
import scipy.sparse as sp

from contact_bench.api import make_case, make_scheme
from contact_bench.harness.runner import problem_for

DOC = Path(__file__).resolve().parents[1] / "docs" / "plugin-api.md"


def _template(tmp_path: Path):
    code = re.findall(r"```python\n(.*?)```", DOC.read_text(encoding="utf-8"), re.S)[0]
    path = tmp_path / "plain_central.py"
    path.write_text(code, encoding="utf-8")
    spec = importlib.util.spec_from_file_location("gap_operator_template", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.PlainCentral()


def _disc():
    case = make_case("disc_drop[degree=1,lift=0.4]")
    return problem_for(case, make_scheme("taylor_flanagan[mass=lumped]"), 2)


def _general(problem, G: sp.csr_matrix, gap0: np.ndarray | None = None):
    contact = dataclasses.replace(problem.contact, dofs=None, operator=sp.csr_matrix(G),
                                  gap0=problem.contact.gap0 if gap0 is None else gap0)
    return dataclasses.replace(problem, contact=contact)


def test_a_selection_given_as_a_general_operator_is_the_same_problem(tmp_path: Path):
    p = _disc()
    G = p.contact.gap_operator(p.nfree)
    q = _general(p, G)
    q.check()
    U = np.random.default_rng(0).normal(size=(3, p.nfree))
    np.testing.assert_array_equal(q.gaps(U), p.gaps(U))
    scheme = _template(tmp_path)
    a = scheme.integrate(p, 0.01, 500, 10)
    b = scheme.integrate(q, 0.01, 500, 10)
    assert a.stress.min() < 0  # it hit the plane
    for field in ("U", "V", "contact_u", "stress", "energy"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))


def test_a_slanted_obstacle_runs_without_penetration(tmp_path: Path):
    """The plane tilted by 0.2 rad: each contact point's gap is its displacement along
    the tilted normal (two entries per row of G); the template stops the points along it
    and keeps every gap >= 0, and the disc slides sideways (x momentum appears)."""
    p = _disc()
    d = np.asarray(p.contact.dofs)  # the y dofs of the contact points (x dofs: d - 1)
    a = 0.2
    n_c = d.size
    rows = np.repeat(np.arange(n_c), 2)
    cols = np.column_stack([d - 1, d]).ravel()
    vals = np.tile([np.sin(a), np.cos(a)], n_c)
    G = sp.csr_matrix((vals, (rows, cols)), shape=(n_c, p.nfree))
    q = _general(p, G, gap0=p.contact.gap0 * np.cos(a))
    q.check()
    traj = _template(tmp_path).integrate(q, 0.01, 500, 10)
    assert traj.stress.min() < 0 and traj.blowup_time is None
    assert traj.min_contact_u >= -1e-12
    x_dofs = np.arange(0, p.nfree, 2)
    momentum_x = traj.V[-1, x_dofs] @ np.asarray(p.M.diagonal())[x_dofs]
    assert abs(momentum_x) > 1e-3


def _slanted(p, a: float = 0.2):
    d = np.asarray(p.contact.dofs)  # the y dofs of the contact points (x dofs: d - 1)
    n_c = d.size
    rows = np.repeat(np.arange(n_c), 2)
    cols = np.column_stack([d - 1, d]).ravel()
    vals = np.tile([np.sin(a), np.cos(a)], n_c)
    G = sp.csr_matrix((vals, (rows, cols)), shape=(n_c, p.nfree))
    return _general(p, G, gap0=p.contact.gap0 * np.cos(a))


def test_the_compiled_kernels_run_a_general_operator(tmp_path: Path):
    """A selection given as a general operator: the compiled steps' numbers to the bit;
    the slanted plane: the compiled lumped Taylor-Flanagan is the template's step (an
    independent plain-numpy implementation) to round-off."""
    p = _disc()
    q = _general(p, p.contact.gap_operator(p.nfree))
    for spec in ("taylor_flanagan[mass=lumped]", "penalty[mass=lumped]", "redistributed"):
        a = make_scheme(spec).integrate(p, 0.01, 500, 10)
        b = make_scheme(spec).integrate(q, 0.01, 500, 10)
        for field in ("U", "V", "contact_u", "stress", "energy"):
            np.testing.assert_array_equal(getattr(a, field), getattr(b, field), err_msg=spec)
    s = _slanted(p)
    mine = _template(tmp_path).integrate(s, 0.01, 500, 10)
    compiled = make_scheme("taylor_flanagan[mass=lumped]").integrate(s, 0.01, 500, 10)
    assert compiled.stress.min() < 0 and compiled.min_contact_u >= -1e-12
    for field in ("U", "V", "contact_u", "stress", "energy"):
        x, y = getattr(mine, field), getattr(compiled, field)
        assert np.max(np.abs(x - y)) <= 1e-10 * max(float(np.max(np.abs(y))), 1.0), field


def test_a_gap_operator_of_the_wrong_shape_is_refused():
    p = _disc()
    q = _general(p, sp.csr_matrix((p.contact.size, p.nfree + 1)))
    with pytest.raises(ValueError, match="gap operator has shape"):
        q.check()
