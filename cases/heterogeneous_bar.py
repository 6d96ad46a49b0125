"""A bar of two materials (E jumps at mid-length): no exact solution, a numerical reference.

L = 1, rho = 1, E = 1 on [0, 1/2) and E = contrast on [1/2, 1] (default 4: wave speeds
1 and 2, impedance ratio 2), g = 0, both ends free; u0 = 0.05 (gap), v0 = -1/2, T = 3.
The bar hits at t = 0.1; the compression wave is partly reflected at the interface, so
the contact ends at a time no closed form gives, and later waves re-impact. Stresses
x-dependent coefficients, reflections inside the bar and a reference that is not exact.

Reference (reference = "numerical"): a fine run of `REFERENCE_SCHEME` with
`REFERENCE_NX` elements and c_max dt / h = `REFERENCE_CFL`, discretised and integrated
directly (not through the harness, which would ask this scene for its reference
again), kept at about `REFERENCE_SAMPLES` samples and interpolated
(`NumericalReference`). It is computed once per process and parameters on
[0, T_ref], T_ref = 1.25 T doubled until it covers the requested time, so a sweep
reuses it. Every report row says that its errors are against a numerical reference.
Provides u, u_t, the (numerical) contact stress and the energy 1/2 rho L v0^2.
"""

from __future__ import annotations

import math
from functools import cache

import numpy as np

from contact_bench.api.params import Param
from contact_bench.api.plugin import BarCase
from contact_bench.exact.numerical import NumericalReference

REFERENCE_SCHEME = "redistributed[variant=mass_conserving]"
REFERENCE_NX = 1000
REFERENCE_CFL = 0.5
REFERENCE_SAMPLES = 4000
GAP, SPEED, INTERFACE = 0.05, 0.5, 0.5


class HeterogeneousBar(BarCase):
    name = "heterogeneous_bar"
    summary = "two materials (E jumps at L/2), free-free impact; numerical reference"
    params = {"contrast": Param(4.0, "E on [L/2, L] / E on [0, L/2)", low=0.1, high=10.0)}
    L, rho, g = 1.0, 1.0, 0.0
    far_end, u_L = "free", 0.0
    T, nx, dt = 3.0, 80, 0.005
    reference = "numerical"
    provides = frozenset({"u", "v", "stress", "energy"})
    contrast: float

    @property
    def E(self):  # type: ignore[override]
        contrast = self.contrast

        def young(x: np.ndarray) -> np.ndarray:
            return np.where(np.asarray(x, float) < INTERFACE * self.L, 1.0, contrast)

        return young

    def u0(self, x: np.ndarray) -> np.ndarray:
        return np.full_like(np.asarray(x, float), GAP)

    def v0(self, x: np.ndarray) -> np.ndarray:
        return np.full_like(np.asarray(x, float), -SPEED)

    def exact(self, T: float) -> NumericalReference:
        T_ref = 1.25 * self.T
        while T_ref < T * (1 - 1e-12):
            T_ref *= 2.0
        return _reference(self.contrast, T_ref)

    @property
    def exact_energy(self) -> float:
        return 0.5 * self.rho * self.L * SPEED**2


@cache
def _reference(contrast: float, T_ref: float) -> NumericalReference:
    """The fine run (once per process and parameters): discretise + scheme.integrate.

    Not `run_one`: that would ask this case for its reference again.
    """
    from contact_bench.api.fem import mesh_nodes
    from contact_bench.api.problem import discretise
    from contact_bench.api.registry import make_scheme

    case = HeterogeneousBar(contrast=contrast)
    scheme = make_scheme(REFERENCE_SCHEME)
    semi = discretise(case, mesh_nodes(case.L, REFERENCE_NX), scheme.mass_kind())
    dt = REFERENCE_CFL * semi.hmin / semi.c_max
    steps = math.ceil(T_ref / dt)
    stride = max(1, math.ceil(steps / REFERENCE_SAMPLES))
    tr = scheme.integrate(semi, dt, steps, stride)
    if tr.blowup_time is not None:
        raise RuntimeError(f"numerical reference of {case.spec} blew up at t = "
                           f"{tr.blowup_time:g}")
    return NumericalReference(
        semi.x, tr.t, semi.full(tr.U), semi.full(tr.V, fill_velocity=True), tr.stress,
        f"{REFERENCE_SCHEME}, nx = {REFERENCE_NX}, dt = {dt:.3g}, stride = {stride}")
