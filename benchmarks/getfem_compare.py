"""Cross-check against GetFEM's demo_dynamic_contact_1D.py (docs/getfem-comparison.md).

Runs GetFEM's demo (its source file, from GetFEM's repository: interface/tests/python/)
under the system Python with GetFEM installed (Debian: `apt-get install python3-getfem`),
then this project's scheme on the same data (clamped_bar, NX = 20, dt = 0.002, T = 12)
and prints how they differ: contact displacement, sampled energy (first step, largest,
final), contact stress at the same sample and one sample later, and the demo's relative
stress error under its exact stress and under this project's (which differ at the
instants contact starts: -1/2 there, 0 here).

    python benchmarks/getfem_compare.py --demo demo_dynamic_contact_1D.py

The demo is run as published except for its `linsolve`: Debian's GetFEM 5.4.2 crashes
(segmentation fault) in `linsolve_superlu` and `linsolve_lu`, so the same direct
sparse solve is done by scipy's SuperLU on the matrix's CSC arrays. Paoli-Schatzman
(version = 1, e_PS = 0, standard mass) is compared for beta = 0 and beta = 1/4.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.plugin import Semidiscrete, Trajectory
from contact_bench.api.problem import discretise
from contact_bench.api.registry import make_case
from contact_bench.core.tridiag import Implicit, factor_pt, pt_solve
from contact_bench.exact.clamped import ClampedBarExact
from contact_bench.kernels.common import (
    allocate,
    bar_ops,
    initial_acceleration,
    run_spec,
    trajectory,
)
from contact_bench.kernels.paoli_schatzman import ps_kernel
from contact_bench.schemes.restitution import run_paoli_schatzman

NX, DT, T = 20, 0.002, 12.0

# run under the system Python: stubs matplotlib (not needed, often not installed), swaps
# the crashing SuperLU call for scipy's, then runs the demo with its own parameters
DRIVER = r'''
import sys, types
import numpy as np, scipy.sparse as sp, scipy.sparse.linalg as spl
plt = types.ModuleType("matplotlib.pyplot")
plt.__getattr__ = lambda name: (lambda *a, **k: None)
mpl = types.ModuleType("matplotlib"); mpl.pyplot = plt
sys.modules["matplotlib"], sys.modules["matplotlib.pyplot"] = mpl, plt
demo, out, params = sys.argv[1], sys.argv[2], sys.argv[3:]
def _spsolve(M, B):
    jc, ir = M.csc_ind()
    A = sp.csc_matrix((np.asarray(M.csc_val()).ravel(), np.asarray(ir).ravel(),
                       np.asarray(jc).ravel()), shape=M.size())
    return spl.spsolve(A, np.asarray(B, float).ravel())
src = open(demo).read()
old = "return (((gf.linsolve_superlu(M, B))[0]).T)[0]"
assert old in src, "the demo's linsolve changed"
src = src.replace(old, "return _spsolve(M, B)")
sys.argv = [demo, *params, "do_final_plot=False", "do_inter_plot=False",
            "do_export_in_files=True", "output_directory=%r" % out]
exec(compile(src, demo, "exec"), {"__name__": "__main__", "_spsolve": _spsolve})
'''


def run_demo(demo: Path, python: str, params: list[str]) -> dict[str, np.ndarray]:
    """The demo's exported u(0, t), v(0, t), stress and energy at every step."""
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([python, "-c", DRIVER, str(demo), tmp, *params], check=True,
                       stdout=subprocess.DEVNULL)
        return {k: np.load(Path(tmp) / f"dyn1d.{k}.npy") for k in ("u0", "v0", "s0", "E")}


def getfem_exact_stress(t: np.ndarray) -> np.ndarray:
    """The demo's exact stress at x = 0 (its uExact(0, t, 1)): -1/2 when t mod 3 lies in
    [1, 2), a half-open interval (this project's: the open one)."""
    return np.where(np.floor(np.mod(t, 3.0)) == 1.0, -0.5, 0.0)


def ps_newmark_start(semi: Semidiscrete, dt: float, nsteps: int, beta: float) -> Trajectory:
    """This project's Paoli-Schatzman kernel (e = 0) started as the demo starts: U^1 by a
    Newmark (trapezoidal) step from (U^0, V^0, A^0), i.e. U^{-1} by a backward one,
    (M + beta dt^2 K) U^{-1} = M (U^0 - dt V^0) + dt^2 (1/2 - beta) M A^0 (no contact
    at t = 0), instead of the Taylor U^{-1} = U^0 - dt V^0 + dt^2/2 A^0."""
    M, K = semi.M, semi.K
    bdt2 = beta * dt * dt
    Sd, Se = factor_pt(M.diag + bdt2 * K.diag, M.off + bdt2 * K.off)
    A0 = initial_acceleration(semi)
    Um = M.matvec(semi.U0 - dt * semi.V0) + dt * dt * (0.5 - beta) * M.matvec(A0)
    pt_solve(Sd, Se, Um)
    w = np.zeros(semi.nfree)
    w[0] = 1.0
    pt_solve(Sd, Se, w)
    out = allocate(semi, nsteps, 1)
    k, done, min_u0, blow = ps_kernel(
        bar_ops(semi), Implicit(Sd, Se, w), Um, semi.U0.copy(), semi.V0.copy(),
        (float(beta), 0.0), run_spec(semi, dt, nsteps, 1), out)
    return trajectory(out, k, done, min_u0, blow, dt)


def rel_l2(s: np.ndarray, ref: np.ndarray) -> float:
    """The demo's stress error: sqrt(sum (s - ref)^2 dt) / sqrt(sum ref^2 dt)."""
    return float(np.sqrt(np.sum((s - ref) ** 2)) / np.sqrt(np.sum(ref**2)))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--demo", type=Path, required=True, help="demo_dynamic_contact_1D.py")
    ap.add_argument("--python", default="/usr/bin/python3",
                    help="a Python that imports getfem (default /usr/bin/python3)")
    args = ap.parse_args(argv)
    steps = int(round(T / DT))
    TT = np.arange(0, T + DT, DT)  # the demo's sample times
    print(f"clamped_bar, NX = {NX}, dt = {DT}, T = {T}; Paoli-Schatzman, e = 0, "
          f"consistent (standard) mass")
    for beta in (0.0, 0.25):
        d = run_demo(args.demo, args.python, ["version=1", "e_PS=0.", "mass_matrix_type=0",
                                               f"beta={beta!r}"])
        semi = discretise(make_case("clamped_bar"), mesh_nodes(1.0, NX), "consistent")
        tr = run_paoli_schatzman(semi, DT, steps, 1, 0.0, beta)
        dE = d["E"] - tr.energy
        print(f"beta = {beta}:")
        print(f"  max |u(0) demo - here|           {np.max(np.abs(d['u0'] - tr.contact_u)):.2e}")
        print(f"  energy: step 1 {dE[1]:+.2e}  max |diff| {np.max(np.abs(dE)):.2e}  "
              f"final {dE[-1]:+.2e} (E(T) here {tr.energy[-1]:.10f})")
        print(f"  stress: max |demo - here| same sample {np.max(np.abs(d['s0'] - tr.stress)):.2e}"
              f", demo one sample later {np.max(np.abs(d['s0'][1:] - tr.stress[:-1])):.2e}")
        alt = ps_newmark_start(semi, DT, steps, beta)
        dA = d["E"] - alt.energy
        print(f"  started as the demo (U^-1 by a backward Newmark step): max |u(0) diff| "
              f"{np.max(np.abs(d['u0'] - alt.contact_u)):.2e}, energy: step 1 {dA[1]:+.2e}, "
              f"final {dA[-1]:+.2e}; stress one sample later "
              f"{np.max(np.abs(d['s0'][1:] - alt.stress[:-1])):.2e}")
        free = (TT > 2.2) & (TT < 3.8)  # no contact: the scheme conserves its energy
        spread = [float(np.ptp(E[free])) for E in (d["E"], tr.energy)]
        print(f"  energy spread over t in (2.2, 3.8) (free flight): demo {spread[0]:.2e}, "
              f"here {spread[1]:.2e}")
        ours = ClampedBarExact().stress(TT)
        theirs = getfem_exact_stress(TT)
        jumps = TT[ours != theirs]
        print(f"  exact stress differs at t = {', '.join(f'{t:.17g}' for t in jumps)}")
        print(f"  demo's stress error: {rel_l2(d['s0'], theirs):.4f} with its exact stress, "
              f"{rel_l2(d['s0'], ours):.4f} with this project's")
    return 0


if __name__ == "__main__":
    sys.exit(main())
