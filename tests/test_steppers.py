"""Prepare once, step many: every sparse stepper (`contact_bench.kernels.stepper`) runs
twice to the same bits, and its `x_sparse` wrapper gives the same trajectory as
`prepare_x(...).run(...)`. The state a kernel mutates in place is copied by `run`, so a
second run starts where the first did."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import pytest

from contact_bench.api.plugin import Trajectory
from contact_bench.api.registry import make_case, make_scheme
from contact_bench.api.sparse import SparseProblem
from contact_bench.kernels.sparse import (
    central_sparse,
    newmark_sparse,
    prepare_central,
    prepare_newmark,
    prepare_quasistatic,
    quasistatic_sparse,
)
from contact_bench.kernels.sparse_explicit import (
    explicit_law_sparse,
    penalty_law,
    prepare_explicit_law,
    prepare_taylor_flanagan,
    taylor_flanagan_sparse,
)
from contact_bench.kernels.sparse_family import (
    adaptive_sparse,
    prepare_adaptive,
    prepare_verlet,
    verlet_sparse,
)
from contact_bench.kernels.sparse_impact import (
    moreau_jean_sparse,
    paoli_schatzman_sparse,
    prepare_moreau_jean,
    prepare_paoli_schatzman,
)
from contact_bench.kernels.stepper import SparseStepper

#: a small P1 disc lifted 0.05: its first impact within the runs below
CASE = "disc_drop[degree=1,lift=0.05]"
NSTEPS, STRIDE = 150, 7


def _kappa(p: SparseProblem) -> np.ndarray:
    return 10.0 * np.full(p.contact.size, float(p.K.diagonal().max()))


#: (id, the scheme whose mass the problem takes, explicit step, prepare(p, dt),
#:  the wrapper (p, dt, nsteps, stride))
STEPPERS: list[tuple[str, str, bool, Callable, Callable]] = [
    ("newmark", "standard", False,
     lambda p, dt: prepare_newmark(p, dt, 0.25, 0.5),
     lambda p, dt, n, s: newmark_sparse(p, dt, n, s, 0.25, 0.5)),
    ("newmark_penalty", "penalty", False,
     lambda p, dt: prepare_newmark(p, dt, 0.25, 0.5, _kappa(p)),
     lambda p, dt, n, s: newmark_sparse(p, dt, n, s, 0.25, 0.5, _kappa(p))),
    ("newmark_hht", "standard", False,
     lambda p, dt: prepare_newmark(p, dt, 0.3, 0.6, alpha=-0.1),
     lambda p, dt, n, s: newmark_sparse(p, dt, n, s, 0.3, 0.6, alpha=-0.1)),
    ("central", "taylor_flanagan[mass=lumped]", True, prepare_central, central_sparse),
    ("quasistatic", "redistributed[beta=0]", True, prepare_quasistatic, quasistatic_sparse),
    ("verlet", "ode_verlet", True, prepare_verlet, verlet_sparse),
    ("adaptive", "ode_adaptive", False,
     lambda p, dt: prepare_adaptive(p, dt, 1e-6),
     lambda p, dt, n, s: adaptive_sparse(p, dt, n, s, 1e-6)),
    ("paoli_schatzman_lumped", "restitution", False,
     lambda p, dt: prepare_paoli_schatzman(p, dt, 0.5, 0.0),
     lambda p, dt, n, s: paoli_schatzman_sparse(p, dt, n, s, 0.5, 0.0)),
    ("paoli_schatzman", "restitution[mass=consistent]", False,
     lambda p, dt: prepare_paoli_schatzman(p, dt, 0.0, 0.25),
     lambda p, dt, n, s: paoli_schatzman_sparse(p, dt, n, s, 0.0, 0.25)),
    ("moreau_jean", "moreau_jean", False,
     lambda p, dt: prepare_moreau_jean(p, dt, 0.5, 0.5),
     lambda p, dt, n, s: moreau_jean_sparse(p, dt, n, s, 0.5, 0.5)),
    ("explicit_law", "penalty[beta=0]", True,
     lambda p, dt: prepare_explicit_law(p, dt, 0.5, penalty_law(p, _kappa(p))),
     lambda p, dt, n, s: explicit_law_sparse(p, dt, n, s, 0.5, penalty_law(p, _kappa(p)))),
    ("explicit_law_massless", "redistributed[beta=0]", True,
     lambda p, dt: prepare_explicit_law(p, dt, 0.5, penalty_law(p, _kappa(p))),
     lambda p, dt, n, s: explicit_law_sparse(p, dt, n, s, 0.5, penalty_law(p, _kappa(p)))),
    ("taylor_flanagan", "taylor_flanagan[mass=consistent]", True, prepare_taylor_flanagan,
     taylor_flanagan_sparse),
]


def _problem(scheme: str, explicit: bool) -> tuple[SparseProblem, float]:
    p = make_case(CASE).sparse_problem(3, 1.0, make_scheme(scheme).mass_kind())
    return p, (0.1 * p.hmin / p.c_max if explicit else 0.01)


def _bits(tr: Trajectory) -> list:
    """Everything a trajectory holds, arrays as bytes (NaN compares equal)."""
    out = [tr.min_contact_u, tr.steps_done, tr.blowup_time, sorted(tr.extra)]
    for a in (tr.t, tr.U, tr.V, tr.contact_u, tr.stress, tr.energy):
        out.append(np.ascontiguousarray(a).tobytes())
    for key in sorted(tr.extra):
        value = tr.extra[key]
        out.append(np.asarray(value).tobytes() if isinstance(value, np.ndarray | float)
                   else value)
    return out


@pytest.mark.parametrize(("name", "scheme", "explicit", "prepare", "wrapper"), STEPPERS,
                         ids=[s[0] for s in STEPPERS])
def test_a_stepper_runs_twice_to_the_same_bits(name, scheme, explicit, prepare, wrapper):
    p, dt = _problem(scheme, explicit)
    stepper = prepare(p, dt)
    assert isinstance(stepper, SparseStepper)
    assert stepper.problem is p and stepper.dt == dt
    first = stepper.run(NSTEPS, STRIDE)
    assert first.steps_done == NSTEPS and first.blowup_time is None
    assert first.extra["contact_steps"] > 0  # the run reaches the contact
    again = stepper.run(NSTEPS, STRIDE)
    assert _bits(again) == _bits(first)
    assert _bits(wrapper(p, dt, NSTEPS, STRIDE)) == _bits(first)


@pytest.mark.parametrize(("name", "scheme", "explicit", "prepare", "wrapper"),
                         [s for s in STEPPERS if s[0] in ("newmark", "verlet")],
                         ids=["newmark", "verlet"])
def test_a_shorter_run_is_the_start_of_a_longer_one(name, scheme, explicit, prepare,
                                                    wrapper):
    """nsteps and stride are the run's: one stepper serves runs of any length."""
    p, dt = _problem(scheme, explicit)
    stepper = prepare(p, dt)
    long = stepper.run(NSTEPS, STRIDE)
    short = stepper.run(7 * STRIDE, STRIDE)
    assert short.t.size == 8
    assert np.array_equal(short.U, long.U[:8]) and np.array_equal(short.energy,
                                                                  long.energy[:8])
