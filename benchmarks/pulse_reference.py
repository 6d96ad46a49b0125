"""How far pulse's former reference (the characteristics solution of its data) is from
its reference now (the d'Alembert solution, `bench/dalembert.py`).

    python benchmarks/pulse_reference.py                      # 20000 cells per length
    python benchmarks/pulse_reference.py --cells 1000 --cells 4000 --points 20000

For each characteristics grid (the former reference had 20000 cells per length): the
largest differences of u, u_x and u_t at random points of [0, L] x [0, T] (seeded), and
of the contact instants; then the d'Alembert table's own error against the closed forms
(`table_error`).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from contact_bench.api.registry import make_case  # noqa: E402
from contact_bench.exact.characteristics import CharacteristicsSolution  # noqa: E402


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--cells", type=int, action="append", default=None,
                   help="cells per length of a characteristics grid (repeatable)")
    p.add_argument("--points", type=int, default=200_000, help="random points")
    args = p.parse_args(argv)
    cells = args.cells or [20000]
    if min(cells) < 1 or args.points < 1:
        p.error(f"--cells and --points must be >= 1, got {min(cells)} and {args.points}")
    case = make_case("pulse")
    ref = case.exact(case.T)
    rng = np.random.default_rng(0)
    x, t = rng.uniform(0.0, case.L, args.points), rng.uniform(0.0, case.T, args.points)
    want = ref.fields(x, t)
    runs = np.array(ref.contact_intervals())
    print(f"{'cells':>6} {'max |du|':>10} {'max |du_x|':>10} {'max |du_t|':>10} "
          f"{'instants':>10}")
    for n in cells:
        old = CharacteristicsSolution(L=case.L, E=case.E, rho=case.rho, far_end=case.far_end,
                                      u_L=case.u_L, u0=case.u0, v0=case.v0, T=case.T,
                                      cells_per_length=n)
        got = old.fields(x, t)
        other = np.array(old.contact_intervals())
        instants = (f"{np.abs(other - runs).max():10.2e}" if other.shape == runs.shape
                    else f"{'differ':>10}")
        print(f"{n:>6} " + " ".join(f"{np.abs(a - b).max():10.2e}" for a, b in zip(
            got, want, strict=True)) + f" {instants}")
    value, slope = ref.table_error()
    print(f"d'Alembert table against the closed forms: {value:.2e} on values, "
          f"{slope:.2e} on slopes; {args.points} random points, seed 0")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
