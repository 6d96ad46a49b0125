"""Accuracy of the prototype against schemes._newmark.run_newmark (beta = 1/4, gamma = 1/2).

    python benchmarks/prototypes/simd_newmark/cmp3.py [newmark_b]

For each run: max relative difference (max |a - b| / max |b|) of U, V, energy and stress
between the prototype ("new") and run_newmark, next to the difference that a 1e-15
relative perturbation of U0 makes in run_newmark itself ("pert"), plus the number of
sampled contact instants and the steps done.
"""
import importlib
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))  # repo root (bench, schemes)

import numpy as np

from bench.fem import mesh_nodes
from bench.problem import discretise
from bench.registry import make_case
from schemes._newmark import run_newmark

RUNS = [  # case, mass, grading, n, nsteps
    ("clamped_bar", "consistent", 1.0, 1000, 300),
    ("clamped_bar", "consistent", 1.0, 1000, 2600),
    ("clamped_bar", "seed", 1.0, 1000, 2600),
    ("dropped_bar", "consistent", 2.0, 1003, 3000),
    ("heterogeneous_bar", "consistent", 1.5, 777, 300),
    ("fast_impact", "seed", 1.3, 5000, 400),
]


def d(a, b):
    """max relative difference of a against b."""
    return np.abs(a - b).max() / max(np.abs(b).max(), 1e-300)


def main(modname):
    mod = importlib.import_module(modname)
    print("case mass grading n steps | U: new pert | V: new pert | E: new pert"
          " | stress: new pert")
    for cname, mass, grading, n, nsteps in RUNS:
        case = make_case(cname)
        semi = discretise(case, mesh_nodes(case.L, n, grading), mass)
        dt = 0.5 * semi.hmin / semi.c_max
        stride = max(1, nsteps // 20)
        r = run_newmark(semi, dt, nsteps, stride, 0.25, 0.5)
        semi2 = discretise(case, mesh_nodes(case.L, n, grading), mass)
        semi2.U0[:] = semi2.U0 * (1 + 1e-15)
        r2 = run_newmark(semi2, dt, nsteps, stride, 0.25, 0.5)
        a = mod.run_a(semi, dt, nsteps, stride)
        print(f"{cname} {mass} {grading} {semi.nfree} {nsteps} "
              f"contact={int((r.stress != 0).sum())} | "
              f"{d(a.U, r.U):.1e} {d(r2.U, r.U):.1e} | {d(a.V, r.V):.1e} {d(r2.V, r.V):.1e} | "
              f"{d(a.energy, r.energy):.1e} {d(r2.energy, r.energy):.1e} | "
              f"{d(a.stress, r.stress):.1e} {d(r2.stress, r.stress):.1e}"
              f" | steps {a.steps_done}/{r.steps_done}")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "newmark_b")
