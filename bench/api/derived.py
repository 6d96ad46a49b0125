"""A scene made from another one: the same body, data, grid and step, another problem.

`curved_drop` (the base's plane become a sphere) and `slanted_drop` (the plane tilted)
take a base scene's spec (their parameter `of`) and change only the sparse problem it
produces. `DerivedScene` holds what such scenes share, so that each scene file holds only
what differs: the base is built and checked in `validate` against `bases` (the scenes it
accepts, each with the index of its vertical axis), and everything that is the body's,
not the problem's, is the base's: its size, impact time, exact energy, assembled body,
footprint, dimension, friction and the schemes it cannot run. A derived scene declares `bases`, its
params (`of` among them) and its `sparse_problem`, and extends `validate` or `cannot_run`
where it differs.
"""

from __future__ import annotations

from typing import Any, ClassVar

from contact_bench.api.plugin import BodyCase, Footprint, Scheme
from contact_bench.api.registry import make_case
from contact_bench.core.errors import BenchError


class DerivedScene(BodyCase):
    """A body scene derived from the scene `of` (module docstring); `self.base` is that
    scene, `self.vertical` the index of its vertical axis."""

    #: the scenes a derived scene accepts as `of`, each with the index of its vertical axis
    bases: ClassVar[dict[str, int]] = {}

    def validate(self) -> None:
        """The base built from `of` (a one-line BenchError names a scene not in `bases`);
        the base's default grid, step, final time and stride taken as this scene's."""
        base = make_case(self.of)
        if base.name not in self.bases:
            raise BenchError(f"{self.spec}: of = {self.of!r}: allowed scenes "
                             f"{', '.join(self.bases)}")
        #: the scene this one derives from: its mesh, material, data, grid and step
        self.base = base
        self.T, self.nx, self.dt, self.stride = base.T, base.nx, base.dt, base.stride

    @property
    def vertical(self) -> int:
        """The index of the base's vertical axis (its gravity's and its plane's normal)."""
        return self.bases[self.base.name]

    @property
    def size(self) -> float:
        return self.base.size

    @property
    def impact_time(self) -> float:
        """The base's first impact time (the body's drop is the base's)."""
        return self.base.impact_time

    @property
    def exact_energy(self) -> float | None:
        return self.base.exact_energy

    @property
    def dim(self) -> int:
        """The base's (`BodyCase.dim`)."""
        return int(self.base.dim)

    def body(self, nx: int) -> Any:
        return self.base.body(nx)

    def footprint(self, nx: int) -> Footprint | None:
        return self.base.footprint(nx)

    def friction(self) -> float:
        return self.base.friction()

    def cannot_run(self, scheme: Scheme) -> str | None:
        return self.base.cannot_run(scheme)
