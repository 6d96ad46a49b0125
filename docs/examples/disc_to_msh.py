"""The built-in disc's mesh written to Gmsh's .msh and read back as `mesh_body`
(docs/mesh-files.md): the same scene from a file.

    python docs/examples/disc_to_msh.py OUT.msh [--nx 5]

writes the disc_drop mesh (nx rings, P2 geometry) with its contact zone (the lower half
of the boundary) as the physical group "contact", reads it back and prints the
`mesh_body` spec that runs it with disc_drop's parameters.
"""

from __future__ import annotations

import argparse

import numpy as np

from contact_bench.api.mesh_file import boundary_group, read_mesh, write_msh
from contact_bench.api.registry import make_case


def disc_to_msh(out: str, nx: int = 5) -> str:
    """Write the disc at nx to `out`; returns the mesh_body spec of the same scene."""
    disc = make_case("disc_drop")
    body = disc.body(nx)
    facets = body.boundary_facets(lambda x: x[1] < disc.centre_y - 0.01 * disc.R)
    write_msh(disc.mesh(nx), out, {"contact": facets})
    back = read_mesh(out)
    assert np.array_equal(back.mesh.doflocs, disc.mesh(nx).doflocs)
    assert np.array_equal(boundary_group(back, "contact"), np.sort(facets))
    return f"mesh_body[file={out},h_contact={disc.R / nx!r}]"


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--nx", type=int, default=5)
    args = ap.parse_args()
    print(disc_to_msh(args.out, args.nx))
