"""Why `standard` blows up on the coarse ball of `oblique_impact` (docs/schemes.md).

For each (spec, nx, dt): the run's status and blow-up time, the largest E / E(0) up to
t = 8, the chatter (contact status switches), and a check of the step against Newmark's
energy balance at every step (stride 1): r_n = M (V_{n+1} - V_n) / dt + K (U_n + U_{n+1}) / 2
- F is the mean contact force of the step, so it must vanish off the contact dofs
(`off contact`: the largest |r| there over the largest |r|), and the energy's change over
the step is then exactly its work (U_{n+1} - U_n).r_n (`balance`: the largest miss over
the largest |dE|). The energy the contact forces put in is split by the steps where the
number of touching contact points (gap <= 1e-12 R) falls (releases) and the others.

    python benchmarks/standard_blowup.py
    python benchmarks/standard_blowup.py --specs "oblique_impact[mu=0]" --nx 4 --dt 0.05
"""

from __future__ import annotations

import argparse
import warnings

import numpy as np

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.harness import run_one


def row(spec: str, nx: int, dt: float, T: float) -> str:
    run = run_one(spec, "standard", nx=nx, T=T, dt=dt, stride=1)
    tr, r = run.trajectory, run.row
    case = make_case(spec)
    p = case.sparse_problem(nx, 1.0, make_scheme("standard").mass_kind())
    t, U, V, E = tr.t, tr.U, tr.V, np.asarray(tr.energy)
    grow = float(np.max(E[t <= 8.0]) / E[0])
    res = (p.M @ np.diff(V, axis=0).T / dt + p.K @ (U[1:] + U[:-1]).T / 2).T - p.F
    G = p.contact.gap_operator(p.nfree)
    on = np.zeros(p.nfree, bool)
    on[G.indices] = True
    off = float(np.abs(res[:, ~on]).max() / np.abs(res).max())
    work = np.einsum("ij,ij->i", np.diff(U, axis=0), res)
    dE = np.diff(E)
    balance = float(np.abs(dE - work).max() / np.abs(dE).max())
    gaps = (G @ U.T).T + p.contact.gap0
    touching = (gaps <= 1e-12 * case.base.R).sum(axis=1)
    release = np.diff(touching) < 0
    return (f"| {spec} | {nx} | {dt:g} | {r['status']} | {r.get('blowup_time')} | {grow:.3g} | "
            f"{r.get('chatter'):.0f} | {off:.1e} | {balance:.1e} | {work[release].sum():+.3g} | "
            f"{work[~release].sum():+.3g} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--specs", default="oblique_impact[mu=0],oblique_impact[mu=0.3]")
    ap.add_argument("--nx", default="2,4")
    ap.add_argument("--dt", default="0.2,0.1,0.05,0.02,0.01,0.005")
    ap.add_argument("--T", type=float, default=30.0)
    a = ap.parse_args()
    warnings.filterwarnings("ignore")
    print("| spec | nx | dt | status | blow-up t | max E/E0 to t 8 | chatter | off contact | "
          "balance | work on releases | work on other steps |")
    print("|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|")
    for spec in a.specs.split(","):
        for nx in a.nx.split(","):
            for dt in a.dt.split(","):
                print(row(spec, int(nx), float(dt), a.T), flush=True)


if __name__ == "__main__":
    main()
