"""Every registered scheme keeps what it declares, on the seed scenes (the scenes of the
default run with an exact reference: `clamped_bar`, `dropped_bar`, and any added one).

One parametrized test (diffrax's `test_ode_order` pattern): the list of schemes comes
from the registry, so adding a scheme adds no test code. For each scheme, its default
parameters, and, when its declared parameters allow it, its explicit variant
(beta = 0, with lumped mass when it takes a `mass`). On `clamped_bar` and
`dropped_bar` at nx = 20, 40, 80 with dt proportional to h (CFL 0.5, or 0.9 x the
declared stability limit when that is smaller):

- a scene the scheme cannot run is a 'not applicable' row with a reason, nothing else;
- stable: no blow-up, every sample finite;
- energy as declared: "conserved" within `energy_drift_bound` (which must then be
  given), "dissipated" no growth beyond that bound (or beyond round-off without one),
  "may grow" nothing claimed;
- penetration within `penetration_bound` + 1e-12 max|U0|;
- unless the scheme claims no convergence (`Traits.order` None), the L2(0,T;L2) error
  on u against the exact solution decreases at each refinement and by at least a
  factor 1.5 from nx = 20 to 80 (order >~ 0.3: impacts cap the order).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.problem import discretise
from contact_bench.api.registry import cases, make_case, make_scheme, schemes
from contact_bench.harness.runner import run_one

#: the seed scenes (in the default run) that have an exact reference
CASES = tuple(n for n, c in cases().plugins.items() if c.in_default_run and c.reference == "exact")
NXS = (20, 40, 80)
CFL = 0.5
SAMPLES = 300  # stride keeps about this many samples per run


def _specs() -> list[str]:
    out = []
    for name, cls in sorted(schemes().plugins.items()):
        out.append(name)
        beta = cls.params.get("beta")
        if beta is not None and beta.low is not None and beta.low == 0.0 and not beta.low_open:
            mass = cls.params.get("mass")
            lumped = mass is not None and mass.choices and "lumped" in mass.choices
            out.append(f"{name}[beta=0,mass=lumped]" if lumped else f"{name}[beta=0]")
    return out


def _dt(spec: str, case_name: str, nx: int) -> float:
    scheme, case = make_scheme(spec), make_case(case_name)
    semi = discretise(case, mesh_nodes(case.L, nx), scheme.mass_kind())
    dt = CFL * semi.hmin / semi.c_max
    limit = scheme.stability_limit(semi)
    if limit is not None:
        dt = min(dt, 0.9 * limit)
    return dt


@pytest.mark.parametrize("case_name", CASES)
@pytest.mark.parametrize("spec", _specs())
def test_scheme_keeps_its_declarations(spec: str, case_name: str) -> None:
    scheme, case = make_scheme(spec), make_case(case_name)
    reason = scheme.cannot_run(case) or case.cannot_run(scheme)
    if reason:
        row = run_one(case, scheme, nx=NXS[0]).row
        assert row["status"] == "not applicable" and row["notes"], row
        return
    traits = scheme.traits()
    errors = []
    for nx in NXS:
        dt = _dt(spec, case_name, nx)
        steps = math.ceil(case.T / dt - 1e-9)
        run = run_one(case, scheme, nx=nx, dt=dt, stride=max(1, steps // SAMPLES))
        row, tr, semi = run.row, run.trajectory, run.semi
        where = f"{spec} on {case_name}, nx={nx}, dt={dt:.4g}"
        # stable under the declared limit
        assert row["status"] == "ok", f"{where}: {row['status']} ({row['notes']})"
        for field in ("U", "V", "energy", "stress"):
            assert np.all(np.isfinite(getattr(tr, field))), f"{where}: {field} not finite"
        # energy as declared
        E = tr.energy
        scale = abs(E[0]) if E[0] != 0 else 1.0
        bound = scheme.energy_drift_bound(semi, dt)
        if traits.energy == "conserved":
            assert bound is not None, f"{spec} declares a conserved energy but no drift bound"
            assert row["energy_drift_max"] <= bound, (where, row["energy_drift_max"], bound)
        elif traits.energy == "dissipated":
            growth = float(np.max(E - E[0])) / scale
            assert growth <= (bound if bound is not None else 1e-9), (where, growth, bound)
        else:
            assert traits.energy == "may grow", f"{spec}: unknown energy trait {traits.energy!r}"
        # penetration as declared
        allowed = scheme.penetration_bound(semi, dt) + 1e-12 * np.max(np.abs(semi.U0))
        assert row["penetration_max"] <= allowed, (where, row["penetration_max"], allowed)
        errors.append(row["err_u_l2_l2"])
    if traits.order is not None:
        decreasing = all(b < a for a, b in zip(errors, errors[1:], strict=False))
        assert decreasing, (spec, case_name, errors)
        assert errors[0] / errors[-1] > 1.5, (spec, case_name, errors)


def test_every_scheme_is_tested_and_none_is_broken() -> None:
    reg = schemes()
    assert not reg.broken, reg.broken
    assert set(reg.plugins) <= {s.split("[")[0] for s in _specs()}
