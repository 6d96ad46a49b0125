"""The implicit step against its solver's floor (issue 48): per configuration and per
factor kind of the loops (`pardiso`: MKL PARDISO's Cholesky, every SPD factor and the
mass's SPD test; `lu`: SuperLU's L and U; `ldlt`: its L and D, `Factor.of(S, ldlt=True)`;
the last two with PARDISO off), the set-up split (assembly, factorisation, contact operators),
one solve of that factor, one implicit step of `redistributed` (every step in contact at
lift 1e-6), their ratio, the solves a step makes (`LU.solves`), W's columns computed (lazy
contact operators: at set-up -> after the run), the contact patch kept
(`contact_bench.kernels.contact.patch_rows`) and the peak memory after the assembly, after
the set-up and at the end.

    python benchmarks/solver_floor.py                      # the issue's three configurations
    python benchmarks/solver_floor.py "disc_drop[degree=2,lift=1e-6]:24" --kinds pardiso,lu
    python benchmarks/solver_floor.py "disc_drop[degree=2,lift=1e-6]:12" --active 1500

`--active N` prints instead how many contact rows a run of N steps puts on the obstacle
(the most at once, and ever) and the largest rank, by initial gap, of a row ever active:
how large the contact patch must be for one solve a step.

A configuration is `scene:nx`; each (configuration, kind) runs in its own process, so
that its peak memory (ru_maxrss) is its own. The step is the mean over `--steps` steps
after one warm-up run of the same length (compilation excluded); the solve the minimum of
`REPEATS` calls. `M K factor GB`: the bytes of M's and K's CSR and of the factor
(`Factor.nbytes`), the must-show's memory floor; `start GB` the process's resident memory
before it builds anything (Python and the suite imported), which the last column takes
off the peak. Times are perturbed by whatever else
runs on the machine.
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import time

import numpy as np
import scipy.sparse as sp

#: the issue's configurations (scene:nx)
CONFIGS = ("disc_drop[degree=2,lift=1e-6]:96", "disc_drop[degree=2,lift=1e-6]:144",
           "sphere_drop[degree=1,lift=1e-6]:32")
REPEATS = 5
#: the clock of the step and the solve: wall time, or with --cpu the process's CPU time
#: (less perturbed by other jobs on a loaded machine; with PARDISO's threads summed, so
#: --cpu sets CONTACT_BENCH_PARDISO_THREADS=1)
CLOCK = time.perf_counter
COLUMNS = ("config", "kind", "dofs", "n_c", "W cols", "patch", "factor entries",
           "assembly s", "factor s", "contact s", "setup s", "solve ms", "step ms",
           "step / solve", "solves / step", "assembly peak GB", "setup peak GB", "peak GB",
           "M K factor GB", "peak / (M K factor)", "start GB",
           "(peak - start) / (M K factor)")


def _peak_gb() -> float:
    """This process's peak resident memory so far (ru_maxrss, VmHWM), GB."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2**20


def solve_seconds(fac) -> float:
    """One solve of a factor (`contact_bench.kernels.linalg.Factor`) by the loops'
    `lu_solve` on a random right-hand side: the least of `REPEATS` calls after one
    (compiling) call, on `CLOCK`. Also benchmarks/scale.py's floor."""
    from contact_bench.kernels.linalg import lu_solve

    n = int(fac.n)
    b, x, w = np.random.default_rng(0).standard_normal(n), np.empty(n), np.empty(n)
    lu_solve(fac.arrays, b, x, w)
    solve = np.inf
    for _ in range(REPEATS):
        t0 = CLOCK()
        lu_solve(fac.arrays, b, x, w)
        solve = min(solve, CLOCK() - t0)
    return float(solve)


def measure(config: str, kind: str, steps: int) -> dict:
    """One (configuration, kind): the row of the table (runs in this process)."""
    from contact_bench.api.registry import make_case, make_scheme
    from contact_bench.core import ordering
    from contact_bench.core.timers import recording
    from contact_bench.kernels import linalg

    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from scale import rss_mib

    start = rss_mib() / 1024  # the process with the suite imported, before building anything
    spec, nx = config.rsplit(":", 1)
    case, sch = make_case(spec), make_scheme("redistributed")
    # the kind decides the assembly's SPD test of the mass too (PARDISO or SuperLU);
    # the module settings are put back afterwards (a test calls this in its process)
    keep = linalg.USE_LDLT, linalg.PARDISO_MIN_DOFS, ordering.pardiso.PARDISO_MIN_DOFS
    linalg.USE_LDLT = kind == "ldlt"
    linalg.PARDISO_MIN_DOFS = ordering.pardiso.PARDISO_MIN_DOFS = (
        0 if kind == "pardiso" else np.iinfo(np.int64).max)
    try:
        t0 = time.perf_counter()
        p = case.sparse_problem(int(nx), 1.0, sch.mass_kind())
        t_asm = time.perf_counter() - t0
        peak_asm = _peak_gb()
        t0 = time.perf_counter()
        with recording() as ph:
            st = sch.prepare(p, float(case.dt))
        t_setup = time.perf_counter() - t0
        peak_setup = _peak_gb()
    finally:
        linalg.USE_LDLT, linalg.PARDISO_MIN_DOFS, ordering.pardiso.PARDISO_MIN_DOFS = keep
    fac, ct = st.factor, st.ops.ct
    n = p.nfree
    cols0 = int(np.count_nonzero(ct.known))  # lazy operators: W's columns at set-up
    solve = solve_seconds(fac)
    st.run(steps, steps)  # compiles
    before = int(fac.arrays.solves[0])
    t0 = CLOCK()
    tr = st.run(steps, steps)
    step = (CLOCK() - t0) / steps
    solves = (int(fac.arrays.solves[0]) - before) / steps
    peak = _peak_gb()
    # W's columns at set-up -> after the run (lazy operators), or "all"
    wcols = f"{cols0}->{int(np.count_nonzero(ct.known))}" if ct.known.size else "all"
    mkf = (sum(m.data.nbytes + m.indices.nbytes + m.indptr.nbytes
               for m in (sp.csr_matrix(p.M), sp.csr_matrix(p.K))) + fac.nbytes) / 2**30
    return {"config": config, "kind": fac.kind, "dofs": n, "n_c": int(ct.gap0.size),
            "W cols": wcols,
            "patch": "whole" if ct.keep_z else int(np.count_nonzero(ct.zcol >= 0)),
            "factor entries": fac.entries, "assembly s": round(t_asm, 2),
            "factor s": round(ph.get("factor", 0.0), 2),
            "contact s": round(ph.get("contact", 0.0), 2),
            "setup s": round(t_setup, 2), "solve ms": round(1e3 * solve, 2),
            "step ms": round(1e3 * step, 2), "step / solve": round(step / solve, 2),
            "solves / step": solves, "in contact": bool(tr.stress[-1] != 0.0),
            "assembly peak GB": round(peak_asm, 2), "setup peak GB": round(peak_setup, 2),
            "peak GB": round(peak, 2), "M K factor GB": round(mkf, 3),
            "peak / (M K factor)": round(peak / mkf, 2), "start GB": round(start, 2),
            "(peak - start) / (M K factor)": round((peak - start) / mkf, 2)}


def active(config: str, nsteps: int) -> dict:
    """The contact rows a run of `nsteps` steps (stride 1) puts on the obstacle."""
    from contact_bench.api.registry import make_case, make_scheme

    spec, nx = config.rsplit(":", 1)
    case, sch = make_case(spec), make_scheme("redistributed")
    p = case.sparse_problem(int(nx), 1.0, sch.mass_kind())
    tr = sch.prepare(p, float(case.dt)).run(nsteps, 1)
    g0 = np.asarray(p.contact.gap0, float)
    on = np.abs(tr.U @ p.contact.gap_operator(p.nfree).T + g0) <= 1e-14  # held exactly
    rank = np.empty(g0.size, np.int64)
    rank[np.argsort(g0, kind="stable")] = np.arange(g0.size)
    ever = np.flatnonzero(on.any(axis=0))
    return {"config": config, "steps": nsteps, "n_c": g0.size,
            "most at once": int(on.sum(axis=1).max()), "ever": ever.size,
            "largest rank": int(rank[ever].max()) if ever.size else -1}


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("configs", nargs="*", default=list(CONFIGS), help="scene:nx")
    ap.add_argument("--kinds", default="pardiso,lu,ldlt",
                    help="factor kinds: pardiso, lu, ldlt")
    ap.add_argument("--steps", type=int, default=20, help="steps timed (after as many warm-up)")
    ap.add_argument("--active", type=int, default=0, metavar="N",
                    help="print the contact rows a run of N steps puts on the obstacle")
    ap.add_argument("--cpu", action="store_true",
                    help="time the step and the solve in CPU time, PARDISO on one thread")
    ap.add_argument("--one", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.active:
        rows = [active(c, a.active) for c in a.configs]
        print("| " + " | ".join(rows[0]) + " |\n|" + "---|" * len(rows[0]))
        for r in rows:
            print("| " + " | ".join(str(v) for v in r.values()) + " |")
        return
    if a.one:  # a child: one configuration, one kind, its row as JSON
        global CLOCK
        CLOCK = time.process_time if a.cpu else time.perf_counter
        print(json.dumps(measure(a.configs[0], a.kinds, a.steps)))
        return
    print("| " + " | ".join(COLUMNS) + " |")
    print("|" + "---|" * len(COLUMNS))
    for config in a.configs:
        for kind in a.kinds.split(","):
            env = dict(os.environ, **({"CONTACT_BENCH_PARDISO_THREADS": "1"} if a.cpu else {}))
            out = subprocess.run([sys.executable, __file__, config, "--kinds", kind,
                                  "--steps", str(a.steps), "--one"] + ["--cpu"] * a.cpu,
                                 capture_output=True, text=True, env=env)
            if out.returncode:
                last = (out.stderr.strip().splitlines() or ["no output"])[-1]
                print(f"| {config} | {kind} | failed: {last} |" + " |" * (len(COLUMNS) - 3))
                continue
            row = json.loads(out.stdout.strip().splitlines()[-1])
            print("| " + " | ".join(str(row[c]) for c in COLUMNS) + " |", flush=True)


if __name__ == "__main__":
    main()
