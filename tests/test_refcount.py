"""The steps compiled without reference counting (`contact_bench.core.refcount`) leak no
reference, allocate nothing, and take no array from a compiled call.

numba's runtime counts every allocation and every release of an array's memory info when
its statistics are on: a run whose step took a reference it never dropped (an array
returned to it by a counted function) leaves a memory info alive, so the allocations and
releases made during the run, the run's own arrays freed, differ. The three midpoint
schemes run their steps uncounted; each runs with contact on the bar, on a curved
obstacle, on two bodies and, the time load's path, on the manufactured square.

A function an uncounted step calls compiles in the step's mode unless it declares its
own (numba inherits the flag), and numba keeps one compiled version per signature,
whichever mode compiled it first: so no compiled function reachable from an uncounted
one may return an array (in the uncounted mode its caller would drop a reference never
taken; in the counted one the step would never drop it) and every one declares its mode.
The last test walks the calls from every uncounted step.
"""

from __future__ import annotations

import ast
import gc
import importlib
import inspect
import pkgutil
import sys
import textwrap
from collections.abc import Callable

import numpy as np
import pytest
from numba.core.errors import TypingError
from numba.core.registry import CPUDispatcher
from numba.core.runtime import _nrt_python, rtsys

from contact_bench import core, kernels
from contact_bench.api.problem import as_problem
from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core import loop
from contact_bench.core.refcount import uncounted
from contact_bench.harness.runner import problem_for
from contact_bench.kernels import energy_conserving, energy_penalty

SCHEMES = ("laursen_love", "laursen_chawla", "armero_petocz")
#: (scene, nx, steps over the scene's T): impacts on the bar; the manufactured square's
#: time load
SCENES = (("clamped_bar", 20, 600), ("manufactured[dim=2]", 2, 20),
          ("curved_drop", 3, 600), ("two_discs", 3, 300))


def _live_meminfos() -> int:
    """Memory infos allocated and not yet released since the statistics were switched on."""
    stats = rtsys.get_allocation_stats()
    return stats.mi_alloc - stats.mi_free


@pytest.mark.parametrize("scheme", SCHEMES)
@pytest.mark.parametrize("scene,nx,steps", SCENES)
def test_an_uncounted_step_leaks_no_reference(scheme: str, scene: str, nx: int,
                                              steps: int) -> None:
    s = make_scheme(scheme)
    case = make_case(scene)
    problem = as_problem(problem_for(case, s, nx), s.mass_kind())
    dt = float(case.T) / steps
    stepper = s.prepare(problem, dt)
    stepper.run(2, 1)  # compiled (or read from the cache) before counting
    gc.collect()
    _nrt_python.memsys_enable_stats()
    try:
        before = _live_meminfos()
        traj = stepper.run(steps, max(1, steps // 10))
        contact = traj.extra["first_contact_start"]
        del traj
        gc.collect()
        after = _live_meminfos()
    finally:
        _nrt_python.memsys_disable_stats()
    assert after == before, f"{after - before} memory infos left alive by the run"
    if scene == "clamped_bar":
        assert np.isfinite(contact), "no contact in the run: the contact path did not run"


def test_an_uncounted_function_cannot_allocate() -> None:
    @uncounted
    def allocates(x):  # pragma: no cover - compiled
        return np.empty(3).sum() + x

    with pytest.raises(TypingError):
        allocates(1.0)


def _callees(fn: Callable) -> list[Callable]:
    """The compiled functions `fn`'s source calls by a module-level name (or module.name),
    and the implementations (`_<name>_compiled`, this code's convention) of the
    overloaded functions it calls."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(fn)))
    names = fn.__globals__
    found = []
    for node in ast.walk(tree):
        if not isinstance(node, ast.Call):
            continue
        f = node.func
        target = names.get(f.id) if isinstance(f, ast.Name) else None
        if isinstance(f, ast.Attribute) and isinstance(f.value, ast.Name):
            target = getattr(names.get(f.value.id), f.attr, None)
        if isinstance(target, CPUDispatcher):
            found.append(target)
        elif inspect.isfunction(target) and target.__module__.startswith("contact_bench"):
            impl = vars(sys.modules[target.__module__]).get(f"_{target.__name__}_compiled")
            if impl is not None:
                found.append(impl)
    return found


def _compiled_functions() -> list[CPUDispatcher]:
    """Every module-level compiled function of contact_bench's core and kernels."""
    found = []
    for pkg in (core, kernels):
        for info in pkgutil.iter_modules(pkg.__path__, pkg.__name__ + "."):
            module = importlib.import_module(info.name)
            found += [f for f in vars(module).values() if isinstance(f, CPUDispatcher)
                      and f.py_func.__module__ == info.name]
    return found


def _returns_a_parameter(fn: CPUDispatcher) -> str | None:
    """The first `return x` of `fn`'s source with x one of its parameters, or None."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(fn.py_func)))
    params = set(inspect.signature(fn.py_func).parameters)
    for node in ast.walk(tree):
        if isinstance(node, ast.Return) and isinstance(node.value, ast.Name):
            if node.value.id in params:
                return node.value.id
    return None


def test_every_function_an_uncounted_one_calls_declares_its_mode() -> None:
    steps = [f for f in _compiled_functions() if f.targetoptions.get("_nrt") is False]
    assert {energy_conserving.midpoint_step, energy_penalty.penalty_midpoint_step,
            loop.smallest_gap, loop.book_forces} <= set(steps)
    seen: set = set()
    todo = list(steps)
    while todo:
        fn = todo.pop()
        if fn in seen:
            continue
        seen.add(fn)
        if not isinstance(fn, CPUDispatcher):  # an overload's implementation: its calls
            todo.extend(_callees(fn))
            continue
        name = fn.py_func.__qualname__
        mode = fn.targetoptions.get("_nrt")
        inlined = fn.targetoptions.get("inline") == "always"
        assert mode is not None or inlined, f"{name}: called by an uncounted step, no mode"
        if mode is False:
            returned = _returns_a_parameter(fn)
            assert returned is None, f"{name} (uncounted) returns its array {returned}"
        if mode is not True:  # a counted helper's callees are counted with it
            todo.extend(_callees(fn.py_func))
    assert len(seen) > len(steps), "the walk found no callee"
