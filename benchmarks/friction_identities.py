"""The sliding block's friction measurements of docs/contact.md and docs/scenes.md.

For each frictional scheme (`Traits.friction`) on `sliding_block` (angle 30 degrees,
nx 2, T 1, stride 1): err_sliding_momentum at mu 0.3 (the momentum identity while every
contact point slides, relative) with the share of samples at which every point slides;
at mu 0.8 from rest the largest tangential momentum |t.M V| beside the elastic
vibration's bound sqrt(m F.K_c^-1 F) (K_c: the stiffness with the contact nodes held,
by scipy), and beside it the largest |t.M V| of the same block from rest at mu 0.3.

    python benchmarks/friction_identities.py [--nx 2] [--T 1.0]
"""

from __future__ import annotations

import argparse

import numpy as np
import scipy.sparse as sp
from scipy.sparse.linalg import spsolve

from contact_bench.api.registry import make_case, make_scheme, schemes
from contact_bench.harness import run_one


def stick_bound(case, p) -> float:
    """sqrt(m F.K_c^-1 F): the kinetic energy bound of a body started at rest under F
    with its contact nodes held, as a momentum along the plane."""
    G, T = p.contact.gap_operator(p.nfree), p.contact.tangents
    held = np.unique(np.concatenate([G.indices, T.indices]))
    free = np.setdiff1d(np.arange(p.nfree), held)
    u = spsolve(sp.csc_matrix(p.K[free][:, free]), p.F[free])
    t = case.tilt.tangent(p)
    return float(np.sqrt((t @ (p.M @ t)) * (p.F[free] @ u)))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nx", type=int, default=2)
    ap.add_argument("--T", type=float, default=1.0)
    a = ap.parse_args(argv)
    names = [n for n in schemes().names() if make_scheme(n).traits().friction]
    print(f"{'scheme':<15}{'err_sliding':>13}{'sliding':>9}{'stick max|p_t|':>16}"
          f"{'bound':>10}{'mu 0.3 max|p_t|':>17}")
    for name in names:
        sch = make_scheme(name)
        row = {}
        for spec in ("sliding_block[angle=30,mu=0.3]", "sliding_block[angle=30,mu=0.8,speed=0]",
                     "sliding_block[angle=30,mu=0.3,speed=0]"):
            case = make_case(spec)
            run = run_one(spec, sch, nx=a.nx, T=a.T, stride=1)
            p = case.sparse_problem(a.nx, 1.0, sch.mass_kind())
            t = case.tilt.tangent(p)
            row[spec] = (case, run, p, float(np.max(np.abs(run.trajectory.V @ (p.M @ t)))))
        case, run, p, _ = row["sliding_block[angle=30,mu=0.3]"]
        share = float(case.sliding(p, run.trajectory.V).mean())
        scase, _, sp_, stick = row["sliding_block[angle=30,mu=0.8,speed=0]"]
        slide = row["sliding_block[angle=30,mu=0.3,speed=0]"][3]
        print(f"{name:<15}{run.row['err_sliding_momentum']:>13.2e}{share:>9.2f}"
              f"{stick:>16.4f}{stick_bound(scase, sp_):>10.4f}{slide:>17.4f}")


if __name__ == "__main__":
    main()
