"""Building a body scene's mesh at a research size logs nothing: scikit-fem warns when it
is given non-contiguous element arrays ("Transforming over 1000 elements to
C_CONTIGUOUS."), which the scenes hand it contiguous, so `contact-bench run` prints no
library chatter."""

from __future__ import annotations

import logging

import pytest

from contact_bench.api import make_case


@pytest.mark.parametrize(("spec", "nx"), [("disc_drop", 20), ("hertz_sphere", 40),
                                          ("sphere_drop", 16)])
def test_a_body_mesh_is_built_without_library_warnings(spec: str, nx: int, caplog) -> None:
    with caplog.at_level(logging.WARNING):
        mesh = make_case(spec).mesh(nx)
    assert mesh.t.shape[1] > 1000  # large enough for scikit-fem's warning
    assert [r.getMessage() for r in caplog.records] == []
