"""Compiled steps without numba's reference counting.

numba's runtime (NRT) counts references to every array a compiled function holds: an
`NRT_incref` call where an array enters a variable (read out of a typed tuple, or an
argument on entry), an `NRT_decref` where the variable dies. llvmlite's pruning removes
a pair only within one basic block or across a simple branch, which a step of dozens of
arrays, branches and calls never meets, so a step pays two calls per array it holds on
every step (docs/reference-counting.md). A step whose arrays all belong to its caller
(its operators and state live as long as the loop that passes them) needs no count.

Each function declares its mode:

* `uncounted_inline`: a scheme's step, the loop's per-step bookkeeping and the small
  helpers they call each step (the gaps, the statistics' updates), compiled with the
  runtime switched off (numba's `_nrt=False`) and inlined into their caller (numba's
  `forceinline`: the loop passes a step's structures without copying their hundreds of
  fields into a call);
* `uncounted`: a helper of theirs with loops over the dofs (a product, a solve), compiled
  the same way as a function of its own (inlined into a large step, its loops compile
  less well: 10 % slower steps on the bar at n = 1000, docs/reference-counting.md);
* `counted`: a helper such a step calls that allocates (the contact solver), compiled
  with reference counting as a function of its own whoever calls it; it takes and drops
  its own references.

The rules, what numba enforces and what `tests/test_refcount.py` checks:

* an uncounted function allocates nothing: numba refuses to compile `np.empty`, fancy
  indexing or an array expression there (a compile error, not a silent leak);
* no compiled function an uncounted one calls returns an array (an uncounted callee's
  would be dropped by a counted caller that never took it; a counted callee's would be
  kept for ever by an uncounted caller); a helper that returns one is inlined into the
  step's source (numba `inline="always"`), compiled in the step's own mode;
* every compiled function an uncounted one calls declares its mode: numba compiles an
  undeclared callee in its caller's mode and keeps one version per signature, whichever
  caller compiled it first.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from numba import njit


def uncounted_inline(fn: Callable[..., Any]) -> Any:
    """`fn` compiled (cached) without reference counting and inlined into its caller: a
    scheme's step over structures its loop owns, the loop's bookkeeping, a small helper
    of theirs (module docstring)."""
    return njit(cache=True, _nrt=False, forceinline=True)(fn)


def uncounted(fn: Callable[..., Any]) -> Any:
    """`fn` compiled (cached) without reference counting as a function of its own: a
    helper of an uncounted step, with loops over the dofs, that allocates nothing and
    returns no array."""
    return njit(cache=True, _nrt=False, forceinline=False)(fn)


def counted(fn: Callable[..., Any]) -> Any:
    """`fn` compiled (cached) with reference counting as a function of its own, also
    where an uncounted step calls it: a helper that allocates."""
    return njit(cache=True, _nrt=True, forceinline=False)(fn)
