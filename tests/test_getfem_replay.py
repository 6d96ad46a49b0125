"""GetFEM's Nitsche demo replayed (`benchmarks/getfem_nitsche_demo.py`):
with the two terms the demo misses (K_N1 U in the initial and in every acceleration) the
replay is this project's Nitsche scheme to round-off."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
from getfem_nitsche_demo import own_energy, replicate_getfem_demo  # noqa: E402

sys.path.pop(0)


@pytest.mark.parametrize(("mass", "theta"), [(0, 1), (0, -1), (1, 1)])
def test_fixed_replay_is_the_scheme(mass: int, theta: int) -> None:
    T = 1.6  # through the first impact at t = 1
    fixed = replicate_getfem_demo(float(theta), mass, True, T=T)
    own = own_energy(theta, mass, T=T)
    assert fixed.size == own.size
    assert np.max(np.abs(fixed[1:] - own[1:])) <= 1e-11
    # t = 0: the demo samples E before computing sigma, so E(0) lacks -theta h/(8 gamma0)
    assert fixed[0] - own[0] == pytest.approx(theta * 0.05 / 40, rel=1e-9)


def test_unfixed_replay_differs() -> None:
    """Without the fix the replay drifts from the scheme (the demo's implementation)."""
    T = 1.6
    demo = replicate_getfem_demo(1.0, 0, False, T=T)
    assert np.max(np.abs(demo[1:] - own_energy(1, 0, T=T)[1:])) > 1e-6
