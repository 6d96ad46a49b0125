"""What numba's reference counting costs a step over typed structures: a micro-benchmark.

A loop calls a compiled `step(o, n)` 2e6 times; `o` is a NamedTuple of 42 arrays of
which the step reads two (a dot product of 20 values). Four variants of the same step:

* `read_first`: the step reads its two arrays first, then computes (and, never taken, a
  branch that allocates): the structure dies in the entry block, numba's pruning pass
  (llvmlite's refprune) removes the references the call took;
* `live_struct`: the same step reading `o.a` again in the allocating branch: `o` lives
  across a branch, the pruning fails, each call counts a reference to each of the 42
  arrays on entry and drops it on exit (`NRT_incref`/`NRT_decref`, 84 calls);
* `live_borrowed`: `live_struct` over a copy of `o` whose arrays carry no reference count
  (numba's meminfo NULL): the 84 calls remain, without their atomic operation;
* `locals`: the base's form, the arrays bound once in the loop's own frame.

Prints CPU time (thread time, best of 5) per call and the NRT call sites in each loop's
IR: the cost is per array and per call, not per array used (docs/reference-counting.md).

    python benchmarks/refcount_micro.py
"""

from __future__ import annotations

import re
import time
from typing import Any, NamedTuple

import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.extending import intrinsic
from numba.np.arrayobj import make_array


class Big(NamedTuple):
    """Two arrays the step reads and 40 it does not."""

    a: np.ndarray
    b: np.ndarray
    pad: tuple


def _no_meminfo(context: Any, builder: Any, ty: Any, val: Any) -> Any:
    """`val` of numba type `ty` with every array's meminfo NULL (tuples recursively)."""
    if isinstance(ty, types.Array):
        arr = make_array(ty)(context, builder, value=val)
        arr.meminfo = cgutils.get_null_value(arr.meminfo.type)
        return arr._getvalue()
    if isinstance(ty, types.BaseTuple):
        for i, t in enumerate(ty.types):
            val = builder.insert_value(
                val, _no_meminfo(context, builder, t, builder.extract_value(val, i)), i)
    return val


@intrinsic
def borrowed(typingctx: Any, t: Any) -> Any:
    """`t` whose arrays carry no reference count (valid while `t` lives)."""
    def codegen(context, builder, sig, args):
        return _no_meminfo(context, builder, sig.args[0], args[0])
    return t(t), codegen


@njit
def dot(a, b):  # pragma: no cover - compiled
    """a . b."""
    s = 0.0
    for i in range(a.size):
        s += a[i] * b[i]
    return s


@njit
def rare(a):  # pragma: no cover - compiled
    """An allocation, on a path never taken."""
    return np.flatnonzero(a).size


@njit
def step_read_first(o, n):  # pragma: no cover - compiled
    """The step reading its two arrays first (`o` dead before the branch)."""
    a, b = o.a, o.b
    s = dot(a, b)
    if n < 0:
        s += rare(a)
    return s


@njit
def step_live(o, n):  # pragma: no cover - compiled
    """The step reading `o.a` again on the allocating branch (`o` lives across it)."""
    s = dot(o.a, o.b)
    if n < 0:
        s += rare(o.a)
    return s


@njit
def loop_read_first(o, steps):  # pragma: no cover - compiled
    """`steps` calls of `step_read_first`."""
    t = 0.0
    for n in range(steps):
        t += step_read_first(o, n)
    return t


@njit
def loop_live(o, steps):  # pragma: no cover - compiled
    """`steps` calls of `step_live`."""
    t = 0.0
    for n in range(steps):
        t += step_live(o, n)
    return t


@njit
def loop_live_borrowed(o, steps):  # pragma: no cover - compiled
    """`steps` calls of `step_live` over `o` without reference counts."""
    ob = borrowed(o)
    t = 0.0
    for n in range(steps):
        t += step_live(ob, n)
    return t


@njit
def loop_locals(o, steps):  # pragma: no cover - compiled
    """The step written into the loop, its arrays bound once (the base's form)."""
    a, b = o.a, o.b
    t = 0.0
    for n in range(steps):
        s = dot(a, b)
        if n < 0:
            s += rare(a)
        t += s
    return t


def main() -> None:
    """Time each variant and count its NRT call sites (module docstring)."""
    o = Big(np.ones(20), np.ones(20), tuple(np.ones(3) for _ in range(40)))
    steps = 2_000_000
    for name, loop in [("read_first", loop_read_first), ("live_struct", loop_live),
                       ("live_borrowed", loop_live_borrowed), ("locals", loop_locals)]:
        assert loop(o, 10) == 200.0
        best = float("inf")
        for _ in range(5):
            t0 = time.thread_time()
            loop(o, steps)
            best = min(best, time.thread_time() - t0)
        ir = loop.inspect_llvm(loop.signatures[0])
        sites = len(re.findall(r"call void @NRT_(?:incref|decref)", ir))
        print(f"{name:14s} {best / steps * 1e9:6.1f} ns a call, {sites} NRT call sites")


if __name__ == "__main__":
    main()
