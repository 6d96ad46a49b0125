"""The numba Newmark kernels agree with the plain scipy reference (bench.reference).

Two kinds of check, both at 1e-12 relative. U, u(0, t) and the energy are compared with
their largest value. The velocity and the contact stress come out of the displacement
form as differences of displacements divided by dt and beta dt^2 (massless node:
(u0^{n+1} - u0^n) / dt; A = (U1 - U~) / (beta dt^2)), so one ulp of U already shows as
ulp(U) / dt in V: they are compared with the larger of their own largest value and that
round-off scale (max|U| / dt, and max|U| (K00 + M00 / (beta dt^2)) for the stress).
- whole trajectories, stride 1, over windows with impacts and take-offs, for the
  massless contact node (redistributed, implicit and explicit), where round-off grows
  slowly;
- the step map of every scheme, standard included, from the same states picked along a
  reference trajectory (before, during and after contact). Whole trajectories of the
  `standard` scheme are not compared: its contact node chatters and each bounce
  amplifies round-off (the kernel and the reference part at 1e-10 after ten contact
  steps, at 1e-5 after two impacts), so only its step map is a meaningful check.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from bench.fem import mesh_nodes
from bench.plugin import Semidiscrete, Trajectory
from bench.problem import discretise
from bench.reference import reference_for
from bench.registry import make_case, make_scheme

TOL = 1e-12


def _assert_agree(a: Trajectory, b: Trajectory, semi: Semidiscrete, dt: float,
                  beta: float) -> None:
    assert a.t.shape == b.t.shape and a.steps_done == b.steps_done
    np.testing.assert_array_equal(a.t, b.t)
    u = np.abs(b.U).max()
    stiff = semi.K.diag[0] + (semi.M.diag[0] / (beta * dt * dt) if beta > 0 else 0.0)
    scale = {"U": u, "contact_u": u, "energy": np.abs(b.energy).max(),
             "V": max(np.abs(b.V).max(), u / dt), "stress": max(np.abs(b.stress).max(), u * stiff)}
    for name, ref_scale in scale.items():
        err = np.abs(getattr(a, name) - getattr(b, name)).max() / ref_scale
        assert err < TOL, (name, err)
    assert a.min_contact_u == pytest.approx(b.min_contact_u, abs=TOL * np.abs(b.U).max())


def _explicit(spec: str) -> bool:
    return "beta=0]" in spec or "beta=0," in spec


def _setup(case_name: str, spec: str, nx: int, dt: float):
    case, scheme = make_case(case_name), make_scheme(spec)
    semi = discretise(case, mesh_nodes(case.L, nx), scheme.mass_kind())
    if _explicit(spec):
        dt = 0.5 * semi.hmin / semi.c_max / np.sqrt(3)
    return scheme, semi, dt


TRAJECTORIES = [  # (case, nx, dt, T): each window holds an impact and (mostly) a take-off
    ("clamped_bar", 16, 0.025, 1.6),
    ("clamped_bar", 20, 0.02, 2.5),
    ("dropped_bar", 16, 0.01, 1.3),
]
MASSLESS = ["redistributed", "redistributed[variant=getfem]",
            "redistributed[variant=conservative]", "redistributed[beta=0.3,gamma=0.7]",
            "redistributed[beta=0]", "redistributed[beta=0,gamma=0.6]"]


@pytest.mark.parametrize("spec", MASSLESS)
@pytest.mark.parametrize("case_name,nx,dt,T", TRAJECTORIES)
def test_trajectories_agree(case_name, nx, dt, T, spec):
    scheme, semi, dt = _setup(case_name, spec, nx, dt)
    nsteps = int(np.ceil(T / dt))
    a = scheme.integrate(semi, dt, nsteps, 1)
    b = reference_for(scheme, semi, dt, nsteps, 1)
    assert (b.stress < 0).sum() >= 5  # impacts are part of the window
    _assert_agree(a, b, semi, dt, scheme.beta)
    # sampling does not change the values
    c = scheme.integrate(semi, dt, nsteps, 7)
    rows = np.unique(np.r_[0:nsteps + 1:7, nsteps])
    np.testing.assert_array_equal(c.U, a.U[rows])
    np.testing.assert_array_equal(c.energy, a.energy[rows])


@pytest.mark.parametrize("spec", ["standard", "standard[beta=0.3,gamma=0.6]",
                                  "redistributed", "redistributed[variant=getfem]",
                                  "redistributed[beta=0]"])
@pytest.mark.parametrize("case_name,nx,dt,T", [("clamped_bar", 20, 0.02, 6.0),
                                               ("dropped_bar", 20, 0.01, 4.5)])
def test_step_map_agrees(case_name, nx, dt, T, spec):
    scheme, semi, dt = _setup(case_name, spec, nx, dt)
    nsteps = int(np.ceil(T / dt))
    ref = reference_for(scheme, semi, dt, nsteps, 1)
    in_contact = np.nonzero(ref.stress < 0)[0]
    picks = np.unique(np.r_[0, in_contact[:: max(1, in_contact.size // 6)],
                            in_contact + 1, np.linspace(0, nsteps - 3, 8).astype(int)])
    picks = picks[picks < nsteps - 3][:40]
    for k in picks:
        start = dataclasses.replace(semi, U0=ref.U[k].copy(), V0=ref.V[k].copy())
        _assert_agree(scheme.integrate(start, dt, 3, 1), reference_for(scheme, start, dt, 3, 1),
                      start, dt, scheme.beta)


def test_reference_covers_only_newmark_schemes():
    with pytest.raises(ValueError, match="no scipy reference"):
        reference_for(type("S", (), {"name": "penalty"})(), None, 0.1, 1, 1)
