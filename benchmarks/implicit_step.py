"""The implicit step of one scene, alone: for comparing two checkouts on one machine.

    python benchmarks/implicit_step.py                       # disc_drop P2 nx 96 (222,338 dofs)
    python benchmarks/implicit_step.py --nx 48 --steps 50

Prepares `redistributed` (implicit) on `disc_drop[degree=2,lift=1e-6]` (touching the
plane from the first step, so every step solves its contact subproblem), runs two steps
(JIT compilation and first touches outside the timing), then times `run(steps, steps)`
`--repeats` times and prints the best and every time per step in ms. It uses only
names that have been public since before the one-loop refactor, so the same file runs
in an old checkout: run it alternately in both, nothing else on the machine.
"""

from __future__ import annotations

import argparse
import time

from contact_bench.api.registry import make_case, make_scheme


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="disc_drop[degree=2,lift=1e-6]")
    ap.add_argument("--scheme", default="redistributed")
    ap.add_argument("--nx", type=int, default=96)
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--repeats", type=int, default=3)
    a = ap.parse_args()
    case, scheme = make_case(a.scene), make_scheme(a.scheme)
    p = case.sparse_problem(a.nx, 1.0, scheme.mass_kind())
    st = scheme.prepare(p, float(case.dt))
    st.run(2, 2)
    per = []
    for _ in range(a.repeats):
        t0 = time.perf_counter()
        st.run(a.steps, a.steps)
        per.append(1e3 * (time.perf_counter() - t0) / a.steps)
    print(f"{a.scheme} on {a.scene} nx {a.nx} ({p.nfree} dofs), dt {case.dt}: "
          f"best {min(per):.2f} ms/step, all {[round(x, 2) for x in per]}")


if __name__ == "__main__":
    main()
