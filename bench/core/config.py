"""Compiler settings shared by every numba kernel of the project, defined once.

`FASTMATH` is the one fastmath flag set a kernel may use: "contract" only lets LLVM fuse
a * b + c into one FMA, which is deterministic on a given machine (the same bits from
run to run); no reassociation and no finite-math assumption, so a NaN or an inf still
reaches the blow-up test. A kernel uses `FASTMATH` or no fastmath at all
(tests/test_kernel_flags.py).
"""

from __future__ import annotations

#: the fastmath flags of the project's kernels (`@njit(fastmath=FASTMATH)`)
FASTMATH = {"contract"}
