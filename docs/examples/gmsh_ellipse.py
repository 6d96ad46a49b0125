"""An elliptic body meshed by Gmsh, for `mesh_body` (docs/mesh-files.md).

The ellipse x^2 / a^2 + (y - b)^2 / b^2 <= 1 (a = 20, b = 12: it touches the plane y = 0
at its lowest point), triangles of size about `h` (P1, or P2 with `--order 2`: the
boundary's midpoints on the curve), its lower half boundary the physical group "contact",
the surface "body". Needs the optional `gmsh` extra (pip install -e ".[gmsh]"). The
bundled cases/meshes/ellipse.msh (mesh_body's default) is `ellipse.msh` of the defaults.

    python docs/examples/gmsh_ellipse.py OUT.msh [--h 4] [--order 1|2]
"""

from __future__ import annotations

import argparse
import math


def ellipse(out: str, h: float = 4.0, order: int = 1, a: float = 20.0, b: float = 12.0) -> str:
    """Mesh the ellipse into `out` (Gmsh's .msh 4.1); returns `out`."""
    import gmsh

    gmsh.initialize(interruptible=False)
    try:
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.model.add("ellipse")
        occ = gmsh.model.occ
        occ.addEllipse(0.0, b, 0.0, a, b, tag=1, angle1=math.pi, angle2=2 * math.pi)
        occ.addEllipse(0.0, b, 0.0, a, b, tag=2, angle1=0.0, angle2=math.pi)
        occ.addCurveLoop([1, 2], tag=1)
        occ.addPlaneSurface([1], tag=1)
        occ.synchronize()
        gmsh.model.addPhysicalGroup(1, [1], name="contact")  # the lower half
        gmsh.model.addPhysicalGroup(1, [2], name="top")
        gmsh.model.addPhysicalGroup(2, [1], name="body")
        gmsh.option.setNumber("Mesh.MeshSizeMax", h)
        gmsh.option.setNumber("Mesh.MeshSizeMin", h / 2)
        gmsh.model.mesh.generate(2)
        gmsh.model.mesh.setOrder(order)
        gmsh.write(out)
    finally:
        gmsh.finalize()
    return out


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out")
    ap.add_argument("--h", type=float, default=4.0)
    ap.add_argument("--order", type=int, default=1, choices=(1, 2))
    args = ap.parse_args()
    print(ellipse(args.out, args.h, args.order))
