"""Why the Khenous-Laborde-Renard mass is or is not positive definite on coarse bodies: per
scene and nx, the contact dofs' share of the scalar dofs and of the mass (row sums), the
smallest eigenvalue of the non-contact block of the least change with every entry free
(against the consistent mass's non-contact block), whether a positive diagonal mass keeps
the same moments (its smallest weight over the mean weight; NaN: none does), and what
`fem_nd.redistributed` returns (SPD from the least change, from the segment to the
diagonal, or refused). Printed as a markdown table (docs/schemes.md quotes it).

    python benchmarks/redistributed_mass.py
    python benchmarks/redistributed_mass.py "sphere_drop:2,4,8" "disc_drop[degree=1]:2,3"
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from contact_bench.api import fem_nd
from contact_bench.api.registry import make_case

DEFAULT = ("sphere_drop:1,2,4,8", "sphere_drop[ball=lattice]:2,3,4,5",
           "sphere_drop[degree=2]:1,2,4", "disc_drop[degree=1]:1,2,3,4", "disc_drop[degree=2]:1,2")


def contact_dofs(case, nx: int):
    """The body and the scalar dofs of its lower half (the scenes' contact zone)."""
    body = case.body(nx)
    axis = body.dim - 1
    centre = case.centre_z if axis == 2 else case.centre_y
    zone = body.boundary_facets(lambda x: x[axis] < centre - 0.01 * case.R)
    return body, np.unique(body.scalar.get_dofs(zone).flatten())


def _smallest(B) -> float:
    return float(np.linalg.eigvalsh(B.toarray()).min())


def row(spec: str, nx: int) -> str:
    body, contact = contact_dofs(make_case(spec), nx)
    ev = fem_nd.redistribution_evidence(body, contact)
    free = np.setdiff1d(np.arange(body.Ms.shape[0]), contact)
    try:
        R = fem_nd.redistributed(body, contact)
    except ValueError:
        outcome, lam = "refused", float("nan")
    else:
        lam = _smallest(R[free][:, free])
        # the segment's point sits on the consistent block's smallest eigenvalue
        on_floor = abs(lam - ev["lambda_min_consistent"]) <= 1e-3 * ev["lambda_min_consistent"]
        outcome = ("segment to the diagonal" if on_floor and not ev["lambda_min"] > 0
                   else "least change")
    return (f"| {spec} | {nx} | {int(ev['dofs'])} | {int(ev['contact_dofs'])} "
            f"({ev['contact_dofs'] / ev['dofs']:.2f}) | {ev['contact_mass_share']:.3f} | "
            f"{ev['lambda_min']:.3g} | {ev['lambda_min_consistent']:.3g} | "
            f"{ev['diagonal_margin']:.3f} | {outcome} | {lam:.3g} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("configs", nargs="*", default=list(DEFAULT), help="scene:nx,nx,...")
    args = ap.parse_args()
    warnings.filterwarnings("ignore")
    print("| scene | nx | scalar dofs | contact dofs (share) | contact mass share | "
          "lambda_min least change | lambda_min consistent | positive diagonal margin | "
          "redistributed | lambda_min result |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---|---:|")
    for config in args.configs:
        spec, nxs = config.rsplit(":", 1)
        for nx in nxs.split(","):
            print(row(spec, int(nx)), flush=True)


if __name__ == "__main__":
    main()
