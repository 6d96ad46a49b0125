"""One blow-up rule: the compiled per-sample test (`blown_up`, in every kernel) and the
array form (`blown_up_rows`, for finished trajectories) agree on every kind of energy."""

from __future__ import annotations

import numpy as np
import pytest

from contact_bench.core.sampling import BLOWUP_FACTOR, blown_up, blown_up_rows

ENERGIES = np.array([0.0, 1.0, -1.0, BLOWUP_FACTOR, -BLOWUP_FACTOR, 1.0001 * BLOWUP_FACTOR,
                     -1.0001 * BLOWUP_FACTOR, np.nan, np.inf, -np.inf, 1e-300, 1e300])


@pytest.mark.parametrize("energy0", [1.0, -1.0, 0.0, 1e-320, 2.5])
def test_array_rule_is_the_kernel_rule(energy0: float) -> None:
    expected = [blown_up(e, energy0) for e in ENERGIES]
    assert blown_up_rows(ENERGIES, energy0).tolist() == expected
    assert blown_up_rows(ENERGIES, energy0)[np.isnan(ENERGIES)].all()
