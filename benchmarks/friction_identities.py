"""The sliding block's friction measurements of docs/contact.md and docs/scenes.md.

For each frictional scheme (`Traits.friction`) on `sliding_block` (angle 30 degrees,
nx 2, T 1, stride 1; `--dim 3` the keeled box, `--degree 2` P2): err_sliding_momentum
at mu 0.3 (the momentum identity while every contact point slides, relative) with the
share of samples at which every point slides; at mu 0.8 from rest the largest tangential
momentum |t.M V| beside the elastic vibration's bound sqrt(m F.K_c^-1 F) (K_c: the
stiffness with the contact nodes touching the plane at t = 0 held, by scipy), and beside
it the largest |t.M V| of the same block from rest at mu 0.3. With `--energy`, for each
scheme and its variants `--also`, at mu 0.3: the friction work at T, its largest value
over the samples (<= 0: dissipative), max |E - W - E(0)| / |E(0)| (the energy with the
dissipated work added back) and max |E - E(0)| / |E(0)|.

    python benchmarks/friction_identities.py [--nx 2] [--T 1.0] [--dim 2] [--degree 1]
    python benchmarks/friction_identities.py --energy [--dim 3]
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
    with its contact nodes touching the plane held, as a momentum along the plane."""
    c = p.contact
    on = np.flatnonzero(c.gap0 == 0.0)
    nt = c.tangents.shape[0] // c.size
    G = c.gap_operator(p.nfree)[on]
    T = c.tangents[(on[:, None] * nt + np.arange(nt)).ravel()]
    held = np.unique(np.concatenate([G.indices, T.indices]))
    free = np.setdiff1d(np.arange(p.nfree), held)
    u = spsolve(sp.csc_matrix(p.K[free][:, free]), p.F[free])
    t = case.tilt.tangent(p)
    return float(np.sqrt((t @ (p.M @ t)) * (p.F[free] @ u)))


def energy(a: argparse.Namespace, names: list[str]) -> None:
    """The friction work and the energy balance at mu 0.3 (module docstring)."""
    spec = f"sliding_block[angle=30,mu=0.3,dim={a.dim},degree={a.degree}]"
    print(f"{'scheme':<40}{'energy':>11}{'W(T)':>11}{'max W':>11}{'E-W drift':>11}"
          f"{'E drift':>10}")
    for name in [*names, *a.also]:
        sch = make_scheme(name)
        tr = run_one(spec, sch, nx=a.nx, T=a.T, stride=1).trajectory
        E, W = np.asarray(tr.energy), tr.extra["friction_work"]
        e0 = abs(float(E[0]))
        print(f"{name:<40}{sch.traits().energy.value:>11}{W[-1]:>11.4f}{np.max(W):>11.1e}"
              f"{np.max(np.abs(E - W - E[0])) / e0:>11.1e}{np.max(np.abs(E - E[0])) / e0:>10.4f}")


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nx", type=int, default=2)
    ap.add_argument("--T", type=float, default=1.0)
    ap.add_argument("--dim", type=int, default=2, choices=(2, 3))
    ap.add_argument("--degree", type=int, default=1, choices=(1, 2))
    ap.add_argument("--energy", action="store_true", help="the friction work's table")
    ap.add_argument("--also", nargs="*", default=["moreau_jean[e=1]",
                                                  "standard[mass=first_element_massless]",
                                                  "penalty[mass=first_element_massless]"])
    a = ap.parse_args(argv)
    names = [n for n in schemes().names() if make_scheme(n).traits().friction]
    if a.energy:
        energy(a, names)
        return
    block = f"dim={a.dim},degree={a.degree}"
    print(f"{'scheme':<15}{'err_sliding':>13}{'sliding':>9}{'stick max|p_t|':>16}"
          f"{'bound':>10}{'mu 0.3 max|p_t|':>17}")
    for name in names:
        sch = make_scheme(name)
        row = {}
        specs = [f"sliding_block[angle=30,mu=0.3,{block}]",
                 f"sliding_block[angle=30,mu=0.8,speed=0,{block}]",
                 f"sliding_block[angle=30,mu=0.3,speed=0,{block}]"]
        for spec in specs:
            case = make_case(spec)
            run = run_one(spec, sch, nx=a.nx, T=a.T, stride=1)
            p = case.sparse_problem(a.nx, 1.0, sch.mass_kind())
            t = case.tilt.tangent(p)
            row[spec] = (case, run, p, float(np.max(np.abs(run.trajectory.V @ (p.M @ t)))))
        case, run, p, _ = row[specs[0]]
        share = float(case.sliding(p, run.trajectory.V).mean())
        scase, _, sp_, stick = row[specs[1]]
        slide = row[specs[2]][3]
        print(f"{name:<15}{run.row['err_sliding_momentum']:>13.2e}{share:>9.2f}"
              f"{stick:>16.4f}{stick_bound(scase, sp_):>10.4f}{slide:>17.4f}")


if __name__ == "__main__":
    main()
