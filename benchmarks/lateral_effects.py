"""How approximate SDNV100's published reference is: the 3D bar with free lateral faces
against the 1D solutions with c_p (the published reference) and c_0 = sqrt(E / rho).

    python benchmarks/lateral_effects.py > results/references/lateral_effects.md

The published problem (cases/aster_sdnv100.py): a steel bar 20 cm long, 2 cm square,
nu = 0.3, hitting a wall at 100 m/s, lateral faces free. Its reference is the 1D
solution with the P-wave speed c_p (exact only when the lateral faces cannot move, the
`sides=sliding` embedded bar). Here the whole section as Q1 hexahedra (`--cells` across,
`--nx` along), free lateral faces, the obstacle under the face x = 0 (frictionless), run
by a scheme (redistributed by default: its mass on the contact face moved to the next
layer, `kron:` of the 1D variant), against both 1D models: impact and release times,
contact duration, the median contact force and the rebound velocity of the centre of
mass (`contact_bench.exact.published.bar_observables`; force on the whole section).
A second run with sliding lateral faces (the published reference's own model, exact)
shows the discretisation's share.
"""

from __future__ import annotations

import argparse
import platform
import shlex
import sys
import time
from datetime import UTC, datetime

import numpy as np
import scipy.sparse as sp
import skfem as fe

from contact_bench.api import fem_nd
from contact_bench.api.registry import make_case, make_scheme
from contact_bench.api.sparse import ContactSet, SparseProblem
from contact_bench.exact.published import bar_observables

QUANTITIES = ("impact_time", "release_time", "contact_duration", "contact_force",
              "rebound_velocity")


def build(nx: int, cells: int, sides: str, mass_kind: str) -> SparseProblem:
    import contact_bench.cases.aster_sdnv100 as sd
    x = np.linspace(0.0, sd.LENGTH, nx + 1)
    y = np.linspace(0.0, sd.SIDE, cells + 1)
    mesh = fe.MeshHex.init_tensor(x, y, y)
    body = fem_nd.assemble(mesh, sd.E_STEEL, sd.NU, sd.RHO)
    M = fem_nd.mass_matrix(body, "kron:" + mass_kind)
    P = body.dof_coordinates
    n = 3 * P.shape[1]
    F = np.zeros(n)
    U = np.zeros(n)
    V = np.zeros(n)
    U[0::3] = sd.GAP
    V[0::3] = -sd.SPEED
    sliding = []
    if sides == "sliding":
        sliding = [lambda q: np.any([np.isclose(q[c], 0.0) | np.isclose(q[c], sd.SIDE)
                                     for c in (1, 2)], axis=0)]
    red = fem_nd.constrain(body, M, F, dirichlet=[], sliding=sliding)
    face = np.flatnonzero(np.isclose(P[0], 0.0, rtol=0, atol=1e-12))
    w = np.zeros(y.size)
    w[:-1] += 0.5 * np.diff(y)
    w[1:] += 0.5 * np.diff(y)
    iy, iz = np.searchsorted(y, P[1][face] - 1e-15), np.searchsorted(y, P[2][face] - 1e-15)
    weights = w[iy] * w[iz]
    contact = ContactSet(dofs=red.index[3 * face], gap0=np.zeros(face.size), weights=weights)
    vertical = np.zeros(n)
    vertical[0::3] = 1.0
    vertical = vertical[red.free]
    Mr = sp.csr_matrix(red.M)
    return SparseProblem(M=Mr, K=red.K, F=red.F, U0=U[red.free], V0=V[red.free],
                         contact=contact, dim=3, hmin=float(min(x[1], y[1])),
                         c_max=sd.C_P, energy_offset=red.energy_offset, mass_kind=mass_kind,
                         E_contact=sd.P_MODULUS, h_contact=float(x[1]),
                         vertical=vertical, body_mass=float(vertical @ (Mr @ vertical)))


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--nx", type=int, action="append")
    ap.add_argument("--cells", type=int, default=4)
    ap.add_argument("--dt", type=float, default=1e-7)
    ap.add_argument("--T", type=float, default=1.3e-4)
    ap.add_argument("--scheme", default="redistributed")
    args = ap.parse_args(argv)
    nxs = args.nx or [50, 100]
    import contact_bench.cases.aster_sdnv100 as sd
    scheme = make_scheme(args.scheme)
    refs = {}
    for wave in ("p", "bar"):
        case = make_case(f"aster_sdnv100[wave={wave}]")
        c = float(np.sqrt(case.E / case.rho))
        refs[wave] = {"impact_time": sd.GAP / sd.SPEED,
                      "release_time": sd.GAP / sd.SPEED + 2 * sd.LENGTH / c,
                      "contact_duration": 2 * sd.LENGTH / c,
                      "contact_force": sd.RHO * c * sd.SPEED * sd.SIDE**2,
                      "rebound_velocity": sd.SPEED}
    cmd = "python benchmarks/lateral_effects.py " + " ".join(shlex.quote(a) for a in
                                                              sys.argv[1:])
    print(f"# SDNV100: the 3D bar with free lateral faces against the 1D references\n\n"
          f"Made by `{cmd}` ({datetime.now(UTC):%Y-%m-%d %H:%M UTC}, Python "
          f"{platform.python_version()}); scheme {scheme.spec}, dt = {args.dt:g} s, "
          f"{args.cells} x {args.cells} Q1 cells across the 2 cm section. Timings on a "
          "shared 2-core machine (perturbed by other jobs).\n")
    print("| model | " + " | ".join(QUANTITIES) + " |")
    print("|---" * (len(QUANTITIES) + 1) + "|")
    for wave, label in (("p", "1D, c_p (published)"), ("bar", "1D, c_0")):
        print(f"| {label} | " + " | ".join(f"{refs[wave][q]:.5g}" for q in QUANTITIES)
              + " |")
    rows = []
    for sides in ("free", "sliding"):
        for nx in nxs:
            p = build(nx, args.cells, sides, scheme.mass_kind())
            steps = int(round(args.T / args.dt))
            start = time.perf_counter()
            traj = scheme.integrate(p, args.dt, steps, 1)
            secs = time.perf_counter() - start
            ones = p.vertical
            obs = bar_observables(p, traj, args.dt, 1.0)
            if traj.V.shape[0]:  # the centre of mass's axial velocity at the end
                m = p.M @ ones
                obs["rebound_velocity"] = float(traj.V[-1] @ m) / float(ones @ m)
            rows.append((sides, nx, obs, secs))
            print(f"| 3D Q1, {sides} sides, nx {nx} ({p.U0.size} dofs, {secs:.0f} s) | "
                  + " | ".join(f"{obs[q]:.5g}" if q in obs else "-" for q in QUANTITIES)
                  + " |", flush=True)
    print("\nRelative differences of the 3D runs from each 1D model:\n")
    print("| run | against | " + " | ".join(QUANTITIES) + " |")
    print("|---" * (len(QUANTITIES) + 2) + "|")
    for sides, nx, obs, _ in rows:
        for wave in ("p", "bar"):
            print(f"| {sides}, nx {nx} | {wave} | " + " | ".join(
                f"{obs[q] / refs[wave][q] - 1:+.3f}" if q in obs else "-"
                for q in QUANTITIES) + " |")


if __name__ == "__main__":
    main()
