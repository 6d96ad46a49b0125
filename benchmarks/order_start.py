"""Measured time order with initial data off a massless contact node's equilibrium.

`contact_bench.sweeps.time_order.SmoothStretch` starts flat near the contact end, so a
massless contact node starts at its equilibrium u0 = u1 (no load). Here the same
measurement also runs on the first free-free mode on a rigid shift, u0 = A (2 + cos(pi x)),
v0 = 0 (smooth, no contact either), whose nodal interpolant has u0 != u1 by O(h^2): a
massless node must jump to its equilibrium in the first step; and on the same nodal
values with node 0 moved to that equilibrium. One row per scheme variant of
`scheme_variants` that declares a massless contact node (read from its traits), with
the order measured on the three; docs/order.md quotes the output.

    python benchmarks/order_start.py
"""

from __future__ import annotations

import numpy as np

from contact_bench.sweeps.time_order import (
    AMPLITUDE,
    SmoothStretch,
    measure_time_order,
    scheme_variants,
)


class CosineMode(SmoothStretch):
    """The first free-free mode on a rigid shift 2A: u0'(0) = 0 but u0(0) != u0(h)."""

    name = "cosine_mode"

    def u0(self, x: np.ndarray) -> np.ndarray:
        return AMPLITUDE * (2.0 + np.cos(np.pi * np.asarray(x, float) / self.L))


class CosineModeAtEquilibrium(CosineMode):
    """The same nodal values, except u0 at x = 0 set to that of the next node: the
    massless node's equilibrium u0 = u1 (uniform bar, no load)."""

    name = "cosine_mode_at_equilibrium"

    def u0(self, x: np.ndarray) -> np.ndarray:
        u = super().u0(x)
        if u.size > 1:
            u[0] = u[1]
        return u


def main() -> None:
    print("| scheme | declared | measured, flat start | measured, cosine mode | "
          "local orders, cosine mode | measured, cosine mode with u0(0) = u0(h) |")
    print("|---|---|---|---|---|---|")
    for scheme in scheme_variants():
        if not scheme.traits().massless_contact_node:
            continue
        flat = measure_time_order(scheme)
        cos = measure_time_order(scheme, case=CosineMode())
        moved = measure_time_order(scheme, case=CosineModeAtEquilibrium())
        local = " ".join(f"{v:.2f}" for v in cos.local)
        print(f"| {scheme.spec} | {flat.declared} | {flat.order:.2f} | {cos.order:.2f} | "
              f"{local} | {moved.order:.2f} |")


if __name__ == "__main__":
    main()
