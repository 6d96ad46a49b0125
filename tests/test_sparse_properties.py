"""Every sparse scene x every registered scheme variant keeps what it declares.

Registry-driven like `test_scheme_properties.py`: the scenes are those whose `Case.form`
is "sparse", each run on its declared small grid (`Case.study`: `small`, `small_nx`,
`small_T`, a short run that holds an impact); the schemes are every registered scheme
with its defaults, its explicit variant (beta = 0, lumped mass when it takes one) and
its lumped-mass variant. Nothing is chosen by name: what is checked comes from the
scheme's declarations (`Traits`):

- a pair that cannot run is a 'not applicable' row with a reason, nothing else;
- the others finish ('ok'; a scheme whose energy "may grow" may blow up instead) with
  finite samples;
- exact contact (`Contact.EXACT`): no penetration beyond round-off;
- energy: "conserved" within the scheme's bound (when it gives one for the problem)
  else CONSERVED_TOL, "dissipated" no growth beyond that bound (else round-off), "may
  grow" nothing; not on a scene with a time-dependent load (`BodyCase.time_load`: the
  load works, the energy is no invariant);
- a scene with a free fall (`quantities` holds it): err_free_fall at round-off;
- a scene with a mirror symmetry: the symmetry defect at round-off for schemes that
  do not chatter (a massless contact node, or a regularised contact: penalty, Nitsche).
"""

from __future__ import annotations

import numpy as np
import pytest

from contact_bench.api.plugin import Contact, Energy
from contact_bench.api.registry import cases, make_case, make_scheme, schemes
from contact_bench.harness.runner import run_one
from contact_bench.sweeps.sweep import drift_bound

SCENES = tuple(n for n, c in sorted(cases().plugins.items()) if c.form == "sparse")
#: relative drift a "conserved" scheme keeps when it gives no bound for the problem
CONSERVED_TOL = 1e-3
#: relative round-off (of the scene's displacement scale)
ROUNDOFF = 1e-8


def _specs() -> list[str]:
    """Every registered scheme: defaults, explicit (beta = 0) and lumped-mass variants."""
    out = []
    for name, cls in sorted(schemes().plugins.items()):
        out.append(name)
        mass = cls.params.get("mass")
        lumped = mass is not None and bool(mass.choices) and "lumped" in mass.choices
        beta = cls.params.get("beta")
        if beta is not None and beta.low == 0.0 and not beta.low_open and beta.default != 0:
            out.append(f"{name}[beta=0,mass=lumped]" if lumped else f"{name}[beta=0]")
        if lumped and mass.default != "lumped":
            out.append(f"{name}[mass=lumped]")
    return out


def _grid(case, scheme) -> int:
    """The scene's smallest declared grid on which it builds the scheme's problem."""
    grid = case.study
    for nx in grid.small_nx[:-1]:
        try:
            case.sparse_problem(nx, 1.0, scheme.mass_kind()).check()
            return nx
        except ValueError:  # e.g. a redistributed mass needs a finer mesh
            continue
    return grid.small_nx[-1]


def test_every_sparse_scene_declares_small_grids() -> None:
    assert SCENES, "no sparse scene registered"
    for name in SCENES:
        grid = cases().plugins[name].study
        assert grid is not None, f"{name}: a sparse scene declares `study` (a StudyGrid)"
        assert grid.small_nx and grid.small_T > 0 and grid.nx and grid.specs, (name, grid)
        assert make_case(grid.small).form == "sparse"


@pytest.mark.parametrize("scene", SCENES)
@pytest.mark.parametrize("spec", _specs())
def test_sparse_scene_keeps_the_declarations(spec: str, scene: str) -> None:
    case = make_case(cases().plugins[scene].study.small)
    scheme = make_scheme(spec)
    if scheme.cannot_run(case) or case.cannot_run(scheme):
        row = run_one(case, scheme, nx=case.study.small_nx[0], T=case.study.small_T).row
        assert row["status"] == "not applicable" and row["notes"], row
        return
    nx = _grid(case, scheme)
    run = run_one(case, scheme, nx=nx, T=case.study.small_T, step_repeats=1)
    row, tr, problem = run.row, run.trajectory, run.semi
    traits = scheme.traits(problem)  # what it claims there (a curved obstacle: less)
    where = f"{spec} on {case.spec}, nx={nx}, dt={row['dt']:.4g}"
    allowed = {"ok", "unstable"} if traits.energy == Energy.MAY_GROW else {"ok"}
    assert row["status"] in allowed, f"{where}: {row['status']} ({row['notes']})"
    assert row["first_contact_start"] is not None and np.isfinite(
        row["first_contact_start"]), f"{where}: no impact in the run"
    scale = float(max(np.abs(problem.U0).max(), case.study.small_T * np.abs(problem.V0).max(),
                      problem.hmin))
    if row["status"] == "ok":
        for name in ("U", "V", "energy", "stress"):
            assert np.all(np.isfinite(getattr(tr, name))), f"{where}: {name} not finite"
    if traits.contact == Contact.EXACT:
        assert row["penetration_max"] <= ROUNDOFF * scale, (where, row["penetration_max"])
    E = np.asarray(tr.energy, float)
    growth = float(np.max(E - E[0])) / (abs(E[0]) or 1.0)
    bound = drift_bound(scheme, problem, float(row["dt"]))  # None: none for this problem
    if getattr(case, "time_load", False):
        pass  # the load's work changes the energy
    elif traits.energy == Energy.CONSERVED:
        tol = CONSERVED_TOL if bound is None else bound
        assert row["energy_drift_max"] <= tol, (where, row["energy_drift_max"], tol)
    elif traits.energy == Energy.DISSIPATED:
        tol = 1e-9 if bound is None else bound
        assert growth <= tol, (where, growth, tol)
    if "free_fall" in case.quantities:
        assert row["err_free_fall"] is not None and row["err_free_fall"] <= 1e-6, (
            where, row["err_free_fall"])
    no_chatter = traits.massless_contact_node or traits.contact in (Contact.PENALTY,
                                                                   Contact.NITSCHE)
    if no_chatter and getattr(problem, "equal_groups", ()):
        assert row["symmetry_defect"] <= ROUNDOFF * scale, (where, row["symmetry_defect"])


def test_every_sparse_scheme_runs_some_scene() -> None:
    """Every scheme runs (some variant of it) on some 2D/3D scene."""
    for name in schemes().plugins:
        ok = [s for s in _specs() if s.split("[")[0] == name
              for scene in SCENES
              if not (make_scheme(s).cannot_run(make_case(cases().plugins[scene].study.small))
                      or make_case(cases().plugins[scene].study.small).cannot_run(
                          make_scheme(s)))]
        assert ok, f"no variant of {name} runs a 2D/3D scene"
