"""The numba Newmark kernels agree with the plain scipy reference
(contact_bench.harness.scipy_reference).

Two kinds of check, both at 1e-12 relative. U, u(0, t) and the energy are compared with
their largest value (on the larger grids the energy is compared as a function of the
compared (U, V): the kernel's value against the reference's formula on the same U, V,
relative to the size of its terms). The velocity and the contact stress come out of the displacement
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
Also: larger grids (n = 100 .. 1000, every row segment of the vector kernels' fused pass)
on step maps, with sampling every 7th step giving the values of sampling every step; and
the smallest systems (n = 1 .. 49: the SPIKE kernels pad to 3 rows per lane block). Both
kernel forms (`contact_bench.kernels.newmark.kernel_form`: serial Thomas below the
crossover, SPIKE above) are also forced at sizes on both sides of the crossover.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.plugin import Scheme, Semidiscrete, Trajectory
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case, make_scheme, schemes
from contact_bench.harness.scipy_reference import _energy, reference_for
from contact_bench.kernels.newmark import (
    FORMS,
    SERIAL_BELOW,
    SPIKE_MIN_DOF_STEPS,
    kernel_form,
    run_newmark,
)

TOL = 1e-12


def _assert_agree(a: Trajectory, b: Trajectory, semi: Semidiscrete, dt: float,
                  beta: float, energy_directly: bool = True) -> None:
    assert a.t.shape == b.t.shape and a.steps_done == b.steps_done
    np.testing.assert_array_equal(a.t, b.t)
    u = np.abs(b.U).max()
    stiff = semi.K.diag[0] + (semi.M.diag[0] / (beta * dt * dt) if beta > 0 else 0.0)
    scale = {"U": u, "contact_u": u,
             "V": max(np.abs(b.V).max(), u / dt), "stress": max(np.abs(b.stress).max(), u * stiff)}
    e_scale = np.abs(b.energy).max()
    if energy_directly:
        scale["energy"] = e_scale
    for name, ref_scale in scale.items():
        err = np.abs(getattr(a, name) - getattr(b, name)).max() / ref_scale
        assert err < TOL, (name, err)
    # the energy is a function of (U, V), compared above; on the same (U, V) the kernel's
    # value equals the reference's formula (on large grids V's round-off, ulp(U) / dt,
    # reaches the energy beyond 1e-12 of its size, so only this check is made there)
    own = np.array([_energy(semi, U, V) for U, V in zip(a.U, a.V, strict=True)])
    sums = max(e_scale, max(_terms(semi, U, V) for U, V in zip(a.U, a.V, strict=True)))
    assert np.abs(a.energy - own).max() / sums < TOL
    assert a.min_contact_u == pytest.approx(b.min_contact_u, abs=TOL * np.abs(b.U).max())


def _terms(semi: Semidiscrete, U: np.ndarray, V: np.ndarray) -> float:
    """The size of the sum that makes the energy: the sum of the magnitudes of its terms
    (1/2 V.M.V + 1/2 U.K.U - F.U + offset), the scale of its summation round-off."""
    def quad(A, x):
        return float(A.diag @ x**2 + 2.0 * np.abs(A.off) @ np.abs(x[:-1] * x[1:]))
    return (0.5 * quad(semi.M, V) + 0.5 * quad(semi.K, U) + float(np.abs(semi.F) @ np.abs(U))
            + abs(semi.energy_offset))


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
# larger grids: the vector kernels' fused pass in all its row segments, the spike
# corrections of both block ends overlapping (m = 7, 8 rows) or apart with rows between
# them (m = 63, ja = jb = 23 at n = 1000); whole trajectories part from the reference
# by round-off growth here (1e-10 .. 1e-7 at n = 1000, as the scalar kernels did), so
# the reference is compared on step maps and sampling on whole trajectories
LARGER = [("clamped_bar", 100, 0.01, 6.0), ("dropped_bar", 120, 0.005, 4.5),
          ("clamped_bar", 1000, 0.0005, 3.0), ("dropped_bar", 1000, 0.0005, 2.5)]
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
    _assert_sampling_keeps_values(scheme, semi, dt, nsteps, a)


def _assert_sampling_keeps_values(scheme, semi, dt, nsteps, every) -> None:
    """Sampling every 7th step gives the values of sampling every step (the kernels'
    sample steps take another path than the others)."""
    c = scheme.integrate(semi, dt, nsteps, 7)
    rows = np.unique(np.r_[0:nsteps + 1:7, nsteps])
    for name in ("U", "V", "contact_u", "stress", "energy"):
        np.testing.assert_array_equal(getattr(c, name), getattr(every, name)[rows], name)


@pytest.mark.parametrize("spec", ["standard", "redistributed", "redistributed[beta=0]"])
@pytest.mark.parametrize("case_name,nx,dt,T", LARGER)
def test_sampling_keeps_values_on_larger_grids(case_name, nx, dt, T, spec):
    scheme, semi, dt = _setup(case_name, spec, nx, dt)
    nsteps = int(np.ceil(min(T, 1.5) / dt))
    every = scheme.integrate(semi, dt, nsteps, 1)
    assert (every.stress < 0).sum() >= 5
    _assert_sampling_keeps_values(scheme, semi, dt, nsteps, every)


@pytest.mark.parametrize("spec", ["standard", "standard[beta=0.3,gamma=0.6]",
                                  "redistributed", "redistributed[variant=getfem]",
                                  "redistributed[beta=0]"])
@pytest.mark.parametrize("case_name,nx,dt,T", [("clamped_bar", 20, 0.02, 6.0),
                                               ("dropped_bar", 20, 0.01, 4.5), *LARGER])
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
                      start, dt, scheme.beta, energy_directly=nx <= 20)


def test_reference_covers_only_newmark_schemes():
    with pytest.raises(ValueError, match="no scipy reference"):
        reference_for(type("S", (Scheme,), {"name": "not_newmark"})(), None, 0.1, 1, 1)
    declared = [n for n, cls in schemes().plugins.items() if cls().newmark_parameters()]
    assert declared  # the built-in Newmark schemes declare it


@pytest.mark.parametrize("form", FORMS)
@pytest.mark.parametrize("spec", ["standard", "redistributed", "redistributed[beta=0]"])
@pytest.mark.parametrize("nx", [2, 3, 8, 31, 32, 33, 48, 49])
def test_small_systems_agree(nx, spec, form):
    """Systems smaller than 3 rows of 16 lanes (padded by the SPIKE form) and around the
    row boundaries, in both kernel forms (the serial one needs n >= 3)."""
    scheme, semi, dt = _setup("clamped_bar", spec, nx, 0.5 / nx)
    nsteps = 30
    _assert_agree(run_newmark(semi, dt, nsteps, 1, scheme.beta, scheme.gamma, form),
                  reference_for(scheme, semi, dt, nsteps, 1),
                  semi, dt, scheme.beta, energy_directly=False)


FORM_SIZES = [20, 100]  # below and above the crossover newmark.SERIAL_BELOW


def test_form_sizes_straddle_the_crossover():
    assert min(FORM_SIZES) < SERIAL_BELOW <= max(FORM_SIZES)
    assert kernel_form(20) == "serial" and kernel_form(SERIAL_BELOW) == "spike"
    assert kernel_form(2) == "spike" and kernel_form(2, form="serial") == "spike"  # n >= 3
    assert kernel_form(100, SPIKE_MIN_DOF_STEPS // 100) == "spike"
    assert kernel_form(100, SPIKE_MIN_DOF_STEPS // 100 - 1) == "serial"  # set-up not paid back
    assert kernel_form(100, 10, form="spike") == "spike"
    with pytest.raises(ValueError, match="kernel form"):
        kernel_form(100, form="thomas")


@pytest.mark.parametrize("form", FORMS)
@pytest.mark.parametrize("nx", FORM_SIZES)
@pytest.mark.parametrize("spec", ["redistributed", "redistributed[beta=0.3,gamma=0.7]",
                                  "redistributed[beta=0]"])
def test_both_forms_agree_on_trajectories(spec, nx, form):
    """Each kernel form, forced at sizes on both sides of the crossover, against the
    reference on whole trajectories (massless node), stride 1 and stride 7."""
    scheme, semi, dt = _setup("clamped_bar", spec, nx, 1.0 / nx)
    nsteps = int(np.ceil(2.5 / dt))
    a = run_newmark(semi, dt, nsteps, 1, scheme.beta, scheme.gamma, form)
    b = reference_for(scheme, semi, dt, nsteps, 1)
    assert (b.stress < 0).sum() >= 5
    _assert_agree(a, b, semi, dt, scheme.beta, energy_directly=nx <= 20)
    c = run_newmark(semi, dt, nsteps, 7, scheme.beta, scheme.gamma, form)
    rows = np.unique(np.r_[0:nsteps + 1:7, nsteps])
    for name in ("U", "V", "contact_u", "stress", "energy"):
        np.testing.assert_array_equal(getattr(c, name), getattr(a, name)[rows], name)


@pytest.mark.parametrize("form", FORMS)
@pytest.mark.parametrize("nx", FORM_SIZES)
@pytest.mark.parametrize("spec", ["standard", "standard[beta=0.3,gamma=0.6]",
                                  "redistributed[variant=getfem]"])
def test_both_forms_agree_on_step_maps(spec, nx, form):
    """Each kernel form against the reference on step maps from states along a reference
    trajectory (before, during and after contact)."""
    scheme, semi, dt = _setup("clamped_bar", spec, nx, 1.0 / nx)
    nsteps = int(np.ceil(4.0 / dt))
    ref = reference_for(scheme, semi, dt, nsteps, 1)
    in_contact = np.nonzero(ref.stress < 0)[0]
    assert in_contact.size >= 3
    picks = np.unique(np.r_[0, in_contact[:: max(1, in_contact.size // 4)], in_contact + 1])
    for k in picks[picks < nsteps - 3][:12]:
        start = dataclasses.replace(semi, U0=ref.U[k].copy(), V0=ref.V[k].copy())
        _assert_agree(run_newmark(start, dt, 3, 1, scheme.beta, scheme.gamma, form),
                      reference_for(scheme, start, dt, 3, 1), start, dt, scheme.beta,
                      energy_directly=nx <= 20)
