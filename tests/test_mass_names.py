"""Mass variants are named after what they do; their older names still parse.

`seed` (the first element massless, as in Dabaghi, Petrov, Pousin, Renard 2014) became
`first_element_massless` and `conservative` became `mass_conserving`: a spec with an old
name builds the same scheme, and prints the new name.
"""

from __future__ import annotations

import numpy as np
import pytest

from contact_bench.api.fem import MASS_ALIASES, MASS_KINDS, assemble, mass_variant, mesh_nodes
from contact_bench.api.registry import make_scheme, schemes


@pytest.mark.parametrize("old, new", MASS_ALIASES)
def test_old_mass_names_parse_to_the_new_ones(old: str, new: str):
    assert new in MASS_KINDS and old not in MASS_KINDS
    for spec, key in ((f"redistributed[variant={old}]", "variant"),
                      (f"hht[mass={old}]", "mass"), (f"standard[mass={old}]", "mass")):
        scheme = make_scheme(spec)
        assert scheme.values[key] == new
        assert old not in scheme.spec
        assert make_scheme(scheme.spec).spec == scheme.spec


def test_every_mass_parameter_accepts_the_old_names():
    """A scheme whose parameter offers a renamed kind also accepts its old name."""
    for cls in schemes().plugins.values():
        for key, param in cls.params.items():
            for old, new in MASS_ALIASES:
                if param.choices is not None and new in param.choices:
                    assert param.convert(cls.name, key, old) == new


@pytest.mark.parametrize("old, new", MASS_ALIASES)
def test_old_name_gives_the_same_mass_matrix(old: str, new: str):
    asm = assemble(mesh_nodes(1.0, 7), 1.0, 1.0)
    a, b = mass_variant(asm, old), mass_variant(asm, new)
    assert np.array_equal(a.diag, b.diag) and np.array_equal(a.off, b.off)


def test_first_element_massless_drops_the_first_element():
    """Total mass L - h (its definition), not L (mass_conserving)."""
    nx = 10
    asm = assemble(mesh_nodes(1.0, nx), 1.0, 1.0)
    total = {k: float(mass_variant(asm, k).matvec(np.ones(nx + 1)).sum())
             for k in ("first_element_massless", "mass_conserving")}
    assert total["first_element_massless"] == pytest.approx(1.0 - 1.0 / nx)
    assert total["mass_conserving"] == pytest.approx(1.0)
