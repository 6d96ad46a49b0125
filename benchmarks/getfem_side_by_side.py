"""GetFEM's disc drop run in GetFEM and in contact-bench on the same mesh and dt, tabulated.

GetFEM's `interface/tests/matlab-octave/demo_dynamic_contact.m` (scheme 2: Newmark beta
1/4, gamma 1/2; P2; disc R 20, lambda = mu = 20, rho 1, body force 0.1, lifted 5, dt 0.01,
T 40) ported to GetFEM's Python interface: Nitsche (theta 1, gamma0 1000) and
multipliers (integral contact brick, P1 multipliers, r 10). It runs in a subprocess
under the system python (`GETFEM_PYTHON`, default /usr/bin/python3; Debian's
python3-getfem), on the mesh of contact-bench's `disc_drop` scene (exported in GetFEM's
GT_PK(2,2) node order), and contact-bench's schemes run the scene on that mesh. One table:
energy against time, contact intervals, peak force, contact on/off switches, time per
step and its ratio to GetFEM's. Conventions in docs/getfem-side-by-side.md.

    python benchmarks/getfem_side_by_side.py [--nx 5] [--T 40] [--out FILE]
    python benchmarks/getfem_side_by_side.py --getfem-mesh GETFEM_SRC/tests/meshes/FILE.mesh
    python benchmarks/getfem_side_by_side.py --demo 1d

`--getfem-mesh`: the other direction. GetFEM loads one of its own mesh files (the .m's
disc_P2_h*.mesh, or sphere_with_quadratic_tetra_*.mesh for its 3D option) and exports it;
contact-bench reads the export (MeshTri2 / MeshTet2, the same nodes) and runs `disc_drop`
or `sphere_drop[degree=2]` on it.

`--demo 1d`: GetFEM's `demo_dynamic_contact_1D.py` (version 0, pure Signorini contact,
Newmark beta 1/4, standard and redistributed mass) run in GetFEM beside contact-bench's
`standard` and `redistributed` on `clamped_bar` at the demo's nx 20, dt 0.002, T 12.

Skipped with a one-line message where GetFEM is absent. The same file is the GetFEM
worker (`--getfem-worker`, run by the system python; it imports no contact_bench).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

GETFEM_PYTHON = os.environ.get("GETFEM_PYTHON", "/usr/bin/python3")


# ------------------------------------------------------------- the GetFEM side (worker)
def getfem_run(mesh_npz: str, contact: str, T: float, dt: float, degree: int = 2,
               lam: float = 20.0, mu: float = 20.0, force: float = 0.1, lift: float = 5.0,
               gamma0: float = 1000.0, theta_N: float = 1.0, r: float = 10.0,
               beta: float = 0.25, gamma: float = 0.5) -> dict:
    """The .m demo's loop (scheme 2, singular_mass 0) for contact 'nitsche' or
    'multipliers'; per step: energy, vertical contact resultant, mean displacement."""
    import getfem as gf
    import scipy.sparse as sp
    from scipy.sparse.linalg import splu

    gf.util_trace_level(0)
    if mesh_npz.endswith(".npz"):  # contact-bench's ring mesh, exported
        m = gf.Mesh("empty", 2)
        m.add_convex(gf.GeoTrans("GT_PK(2,2)"), np.load(mesh_npz)["nodes"])
    else:  # a GetFEM mesh file, loaded as the demo does
        m = gf.Mesh("load", mesh_npz)
    d, GAMMAC = m.dim(), 1
    border = m.outer_faces()
    normals = m.normal_of_faces(border)
    m.set_region(GAMMAC, border[:, np.nonzero(normals[d - 1] < -0.01)[0]])
    mfu = gf.MeshFem(m, d)
    mfu.set_classical_fem(degree)
    mfd = gf.MeshFem(m, 1)
    mfd.set_classical_fem(degree)
    mflambda = gf.MeshFem(m, 1)
    mflambda.set_classical_fem(1)
    mim = gf.MeshIm(m, 4)
    mim_c = gf.MeshIm(m, gf.Integ("IM_STRUCTURED_COMPOSITE(IM_TRIANGLE(4),4)" if d == 2 else
                                  "IM_STRUCTURED_COMPOSITE(IM_TETRAHEDRON(5),4)"))
    M = gf.asm_mass_matrix(mim, mfu)
    nbdofd, nbdofu = mfd.nbdof(), mfu.nbdof()
    F = np.zeros((d, nbdofd))
    F[d - 1, :] = -force
    md = gf.Model("real")
    md.add_fem_variable("u", mfu)
    md.add_initialized_data("cmu", [mu])
    md.add_initialized_data("clambda", [lam])
    md.add_isotropic_linearized_elasticity_brick(mim, "u", "clambda", "cmu")
    Ms = gf.Spmat("copy", M)
    Ms.scale(1.0 / (dt * dt * beta))
    md.add_explicit_matrix("u", "u", Ms)
    ind_rhs = md.add_explicit_rhs("u", np.zeros(nbdofu))
    md.add_initialized_fem_data("volumicload", mfd, F)
    md.add_source_term_brick(mim, "u", "volumicload")
    md.add_initialized_fem_data("obstacle", mfd, mfd.eval("y" if d == 2 else "z"))
    if contact == "nitsche":
        md.add_initialized_data("gamma0", [gamma0])
        md.add_initialized_data("theta_N", [theta_N])
        md.add_Nitsche_contact_with_rigid_obstacle_brick(
            mim_c, "u", md.Neumann_term("u", GAMMAC), "obstacle", "gamma0", GAMMAC, theta_N)
    else:
        mflp = gf.MeshFem("partial", mflambda, mflambda.dof_on_region(GAMMAC))
        md.add_fem_variable("lambda", mflp)
        md.add_initialized_data("r", [r])
        md.add_integral_contact_with_rigid_obstacle_brick(mim_c, "u", "lambda", "obstacle",
                                                          "r", GAMMAC, 1)
    U0 = np.zeros(nbdofu)
    U0[d - 1::d] = lift
    MU0, MV0 = M.mult(U0), np.zeros(nbdofu)
    FF = gf.asm_volumic_source(mim, mfu, mfd, F)
    Kfull = gf.asm_generic(mim, 2, "(clambda*Div_u*Id(meshdim)+2*cmu*Sym(Grad_u)):Grad_Test_u",
                           -1, md)
    start, size = md.interval_of_variable("u")
    Iu = list(range(start, start + size))
    K = gf.Spmat("copy", Kfull, Iu, Iu)
    K2 = K
    if contact == "nitsche":
        KK = gf.asm_generic(mim, 2, "(-theta_N*element_size/gamma0)*((clambda*Div_u*Id(meshdim)"
                            "+2*cmu*Sym(Grad_u))*Normal).((clambda*Div_Test_u*Id(meshdim)"
                            "+2*cmu*Sym(Grad_Test_u))*Normal)", GAMMAC, md)
        K2 = gf.Spmat("add", K, gf.Spmat("copy", KK, Iu, Iu))
    MA0 = FF - K2.mult(U0)
    jc, ir = M.csc_ind()
    Mlu = splu(sp.csc_matrix((M.csc_val(), ir, jc), shape=(nbdofu, nbdofu)))
    mass = -float(np.sum(FF[d - 1::d])) / force
    ydofs = np.arange(d - 1, nbdofu, d)
    NT = int(round(T / dt))
    E, Rc, ybar = np.zeros(NT + 1), np.zeros(NT + 1), np.zeros(NT + 1)
    E[0] = 0.5 * U0 @ K.mult(U0) - FF @ U0
    ybar[0] = float(np.sum(MU0[ydofs])) / mass
    scheme_s = 0.0
    t0 = time.perf_counter()
    for nit in range(1, NT + 1):
        ts = time.perf_counter()
        LL = (MU0 + dt * MV0 + dt * dt * (0.5 - beta) * MA0) / (beta * dt * dt)
        md.set_private_rhs(ind_rhs, LL)
        md.solve("max_res", 1e-8, "max_iter", 100)
        U1 = md.variable("u")
        MU1 = M.mult(U1)
        MA1 = (MU1 - MU0 - dt * MV0 - dt * dt * (0.5 - beta) * MA0) / (dt * dt * beta)
        MV1 = MV0 + dt * (gamma * MA1 + (1 - gamma) * MA0)
        scheme_s += time.perf_counter() - ts
        V1 = Mlu.solve(MV1)
        E[nit] = 0.5 * (V1 @ MV1 + U1 @ K.mult(U1)) - FF @ U1
        # the vertical contact resultant by the momentum balance (ker K holds translations)
        Rc[nit] = float(np.sum(MA1[ydofs]) - np.sum(FF[ydofs]))
        ybar[nit] = float(np.sum(MU1[ydofs])) / mass
        U0, MU0, MV0, MA0 = U1, MU1, MV1, MA1
    return {"E": E.tolist(), "Rc": Rc.tolist(), "ybar": ybar.tolist(), "mass": mass,
            "ndofs": int(nbdofu), "seconds_per_step": scheme_s / NT,
            "seconds_per_step_total": (time.perf_counter() - t0) / NT}


def getfem_export(mesh_file: str, out: str) -> None:
    """A GetFEM mesh file as GetFEM reads it: its points, every convex's point ids in
    GetFEM's order, and the number of faces of the contact zone (outward n_d < -0.01)."""
    import getfem as gf

    m = gf.Mesh("load", mesh_file)
    cv = m.cvid()
    pid, idx = m.pid_from_cvid(cv)
    nn = np.diff(idx)
    if np.any(nn != nn[0]):
        raise SystemExit(f"{mesh_file}: convexes of several kinds")
    border = m.outer_faces()
    normals = m.normal_of_faces(border)
    np.savez(out, points=m.pts(), cells=np.asarray(pid).reshape(-1, nn[0]),
             geotrans=str(m.geotrans(cv[:1])[0]),
             contact_faces=int(np.sum(normals[m.dim() - 1] < -0.01)))


def getfem_1d_run(mass_type: int, NX: int = 20, T: float = 12.0, dt: float = 0.002,
                  beta: float = 0.25, gamma: float = 0.5) -> dict:
    """GetFEM's `interface/tests/python/demo_dynamic_contact_1D.py`, version 0 (pure
    Signorini contact), implicit branch, P1, in GetFEM: its matrices, Dirichlet rows and
    updates; mass_type 0 standard, 1 redistributed (M11 += M00 + M01). Linear solves by
    GetFEM's MUMPS (its SuperLU binding crashes in Debian's 5.4). Energy of every step."""
    import getfem as gf

    gf.util_trace_level(0)

    def solve(A, b):
        return np.asarray(gf.linsolve_mumps(A, b)).ravel()

    m = gf.Mesh("cartesian", np.arange(0, 1 + 1.0 / NX, 1.0 / NX))
    mfu = gf.MeshFem(m)
    mfu.set_classical_fem(1)
    mim = gf.MeshIm(m, 4)
    md = gf.Model("real")
    md.add_fem_variable("u", mfu)
    U0 = mfu.eval("0.5-0.5*x").ravel()
    n = U0.size
    V0 = np.zeros(n)
    M = gf.asm_generic(mim, 2, "u*Test_u", -1, md)
    K = gf.asm_generic(mim, 2, "Grad_u*Grad_Test_u", -1, md)
    for i in range(2):
        K[n - 1, n - 2 + i] = 0.0
        M[n - 1, n - 2 + i] = 0.0
    M[n - 1, n - 1] = 1.0
    K[n - 1, n - 1] = 1.0
    M2 = gf.Spmat("copy", M)
    if mass_type == 1:
        M[1, 1] += M[0, 0]
        M[0, 0] = 0.0
        M[1, 1] += M[1, 0]
        M[0, 1] = M[1, 0] = 0.0
        M2 = gf.Spmat("copy", M)
        M2[0, 0] = 1.0
    MV0 = M.mult(V0)
    MA0 = -K.mult(U0)
    if mass_type >= 1:
        MA0[0] = 0.0
    K_m = gf.Spmat("copy", K)
    K_m.scale(dt * dt * beta)
    K_N = gf.Spmat("add", M, K_m)
    K_N_C = gf.Spmat("copy", K_N)
    for i in range(2):
        K_N_C[0, i] = 0.0
    K_N_C[0, 0] = 1.0
    NT = int(round(T / dt)) + 1
    E, u_contact = np.zeros(NT), np.zeros(NT)
    start = time.perf_counter()
    for nit in range(NT):
        if nit > 0:
            B = M.mult(U0) + dt * MV0 + (dt * dt * (1 - 2 * beta) / 2.0) * MA0
            U1 = solve(K_N, B)
            MV1 = np.copy(MV0)
            if U1[0] < 0:
                B2 = np.copy(B)
                B2[0] = 0.0
                U1 = solve(K_N_C, B2)
                Fc1 = (K_N.mult(U1) - B) / (beta * dt * dt)
            else:
                Fc1 = np.zeros(n)
            MA1 = Fc1 - K.mult(U1)
            MV1 += dt * ((1.0 - gamma) * MA0 + gamma * MA1)
            V1 = solve(M2, MV1)
            V1[n - 1] = 0.0
            if mass_type >= 1:
                V1[0] = (U1[0] - U0[0]) / dt
            MA0 = MA1
            U0, V0, MV0 = U1, V1, MV1
        E[nit] = 0.5 * (M.mult(V0) @ V0 + K.mult(U0) @ U0)
        u_contact[nit] = U0[0]
    return {"E": E.tolist(), "u_contact": u_contact.tolist(),
            "seconds_per_step": (time.perf_counter() - start) / (NT - 1)}


# ----------------------------------------------------------- the contact-bench side
def export_mesh(case, nx: int, path: str) -> None:
    """The scene's P2-geometry triangles as (2, 6, elements) points in GetFEM's GT_PK(2,2)
    order: vertex 0, mid 01, vertex 1, mid 02, mid 12, vertex 2 (scikit-fem's facets of
    a triangle are 01, 12, 02)."""
    m = case.mesh(nx)
    V = m.doflocs[:, m.t]
    mid = m.doflocs[:, m.nvertices + m.t2f]
    np.savez(path, nodes=np.stack([V[:, 0], mid[:, 0], V[:, 1], mid[:, 2], mid[:, 1],
                                   V[:, 2]], axis=1))


#: GetFEM's quadratic simplices: the local ids of the vertices, and of each edge's
#: midpoint with its two vertices (GT_PK(d,2) orders its nodes by barycentric coordinates)
_GT_PK2 = {2: ((0, 2, 5), ((1, 0, 2), (3, 0, 5), (4, 2, 5))),
           3: ((0, 2, 5, 9), ((1, 0, 2), (3, 0, 5), (4, 2, 5), (6, 0, 9), (7, 2, 9),
                              (8, 5, 9)))}


def read_getfem_mesh(path: str):
    """GetFEM's exported quadratic triangles or tetrahedra (`getfem_export`) as a
    scikit-fem MeshTri2 or MeshTet2: the vertices and every edge's midpoint node."""
    import skfem as fe

    z = np.load(path)
    P, C = np.asarray(z["points"], float), np.asarray(z["cells"], np.int64)
    d = P.shape[0]
    if d not in _GT_PK2 or C.shape[1] != (6 if d == 2 else 10):
        raise ValueError(f"{path}: {z['geotrans']} is not a quadratic simplex (GT_PK(d,2))")
    corners, mids = _GT_PK2[d]
    verts, t = np.unique(C[:, corners], return_inverse=True)
    t = t.reshape(-1, d + 1).T
    linear = (fe.MeshTri1 if d == 2 else fe.MeshTet1)(P[:, verts], t)
    m = (fe.MeshTri2 if d == 2 else fe.MeshTet2).from_mesh(linear)
    number = {int(v): k for k, v in enumerate(verts)}
    midpoint = {}
    for cell in C:
        for k, a, b in mids:
            midpoint[frozenset((number[int(cell[a])], number[int(cell[b])]))] = cell[k]
    edges = m.facets if d == 2 else m.edges  # scikit-fem's edge dofs follow the vertices
    loc = m.doflocs.copy()
    loc[:, m.nvertices:] = P[:, [midpoint[frozenset(e)] for e in edges.T.tolist()]]
    from dataclasses import replace

    return replace(m, doflocs=loc)


def on_mesh(case, mesh):
    """The scene on another mesh: a copy whose `mesh(nx)` is `mesh` (the scene assembles
    everything else from it)."""
    import copy

    other = copy.copy(case)
    other.mesh = lambda nx: mesh
    return other


def bench_run(case, scheme_spec: str, nx: int, dt: float, T: float,
              h_contact: float | None = None) -> dict:
    """One contact-bench scheme on the scene, every step recorded (stride 1)."""
    from dataclasses import replace

    from contact_bench.api.registry import make_scheme

    scheme = make_scheme(scheme_spec)
    p = case.sparse_problem(nx, 1.0, scheme.mass_kind())
    if h_contact is not None:
        p = replace(p, h_contact=h_contact)
    nsteps = int(round(T / dt))
    scheme.integrate(p, dt, 1, 1)  # compilation outside the timing
    start = time.perf_counter()
    traj = scheme.integrate(p, dt, nsteps, 1)
    wall = time.perf_counter() - start
    Mc = case.sparse_problem(nx, 1.0, "consistent").M
    mass = p.body_mass
    ybar = (traj.U @ (Mc @ p.vertical)) / mass
    return {"E": traj.energy.tolist(), "Rc": (-traj.stress * p.contact.weights.sum()).tolist(),
            "ybar": ybar.tolist(), "mass": mass, "ndofs": p.nfree,
            "seconds_per_step": wall / nsteps}


def intervals(R: np.ndarray, dt: float, thr: float) -> list[tuple[float, float]]:
    """Maximal runs of steps with a contact resultant above thr, as (start, end) times."""
    on = np.r_[False, R > thr, False]
    edges = np.flatnonzero(np.diff(on.astype(int)))
    return [(float((a - 1) * dt + dt), float((b - 1) * dt)) for a, b in
            zip(edges[::2], edges[1::2], strict=True)]


def table(results: dict[str, dict], dt: float, T: float, E0_exact: float,
          body: str = "disc") -> str:
    """The markdown tables of the runs."""
    ref = results.get("GetFEM Nitsche", {}).get("seconds_per_step")
    times = [t for t in (0, 5, 10, 15, 20, 25, 30, 35, 40) if t <= T]
    lines = ["| code, method | dofs | E(t) / E0 at t = " + ", ".join(map(str, times))
             + " | max abs(E / E0 - 1) | contact intervals | peak force | switches |"
             " free fall: max abs error of mean u_y / lift, t < 10 | s per step |"
             " GetFEM Nitsche / this |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for name, r in results.items():
        E = np.asarray(r["E"])
        R = np.asarray(r["Rc"])
        E0 = E[0]
        thr = 1e-8 * r["mass"] * 0.1
        iv = intervals(R, dt, thr)
        shown = ", ".join(f"[{a:.2f}, {b:.2f}]" for a, b in iv[:3])
        if len(iv) > 3:
            shown += f", ... ({len(iv)} in all)"
        t = dt * np.arange(E.size)
        fall = t < 10.0 - dt / 2  # the exact free fall, mean u_y = 5 - g t^2 / 2
        ff = np.max(np.abs(np.asarray(r["ybar"])[fall] - (5.0 - 0.05 * t[fall] ** 2))) / 5.0
        ratio = f"{ref / r['seconds_per_step']:.1f}" if ref else ""
        lines.append(
            f"| {name} | {r['ndofs']} | "
            + " ".join(f"{E[k] / E0:.4f}" if k < E.size else "(blew up)"
                       for k in (int(round(t / dt)) for t in times))
            + f" | {np.max(np.abs(E / E0 - 1)):.3g} | {shown or 'none'} | {R.max():.4g} | "
            f"{2 * len(iv) - (1 if iv and iv[-1][1] >= T - dt / 2 else 0)} | "
            f"{ff:.2g} | {r['seconds_per_step'] * 1e3:.3g} ms | {ratio} |")
    lines.append("")
    lines.append(f"E0 = m g lift = {E0_exact:.6g} for the continuous {body}. Switches: contact "
                 "on/off changes of the body (vertical resultant above 1e-8 m g).")
    return "\n".join(lines)


def table_1d(python: str) -> str:
    """GetFEM's 1D demo (version 0, implicit) beside contact-bench on clamped_bar, nx 20,
    dt 0.002, T 12: energy differences relative to E0 = 1/8."""
    from contact_bench.harness.runner import run_one

    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "1d.json")
        subprocess.run([python, os.path.abspath(__file__), "--getfem-1d", out], check=True)
        with open(out) as f:
            gf = json.load(f)
    lines = ["| GetFEM 1D demo mass | contact-bench scheme | max abs(E_cb - E_gf) / E0, t < 1 |"
             " same, t <= 12 | first step with another contact status | E(12) GetFEM |"
             " E(12) contact-bench | s per step GetFEM / contact-bench |",
             "|---|---|---|---|---|---|---|---|"]
    for mt, spec in (("0", "standard"), ("1", "redistributed[variant=getfem]"),
                     ("1", "redistributed")):
        run = run_one("clamped_bar", spec, nx=20, dt=0.002, T=12.0, stride=1)
        E, G = run.trajectory.energy, np.asarray(gf[mt]["E"])
        d = np.abs(E - G) / G[0]
        u, g = run.trajectory.contact_u, np.asarray(gf[mt]["u_contact"])
        other = np.flatnonzero((u == 0) != (g == 0))
        first = f"{other[0]} (t = {other[0] * 0.002:.3f})" if other.size else "none"
        cb = run.row["wall_s"] / 6000
        lines.append(f"| {'standard' if mt == '0' else 'redistributed'} | {spec} | "
                     f"{d[:500].max():.2g} | {d.max():.2g} | {first} | {G[-1]:.12g} | "
                     f"{E[-1]:.12g} | {gf[mt]['seconds_per_step'] * 1e3:.3g} ms / "
                     f"{cb * 1e6:.3g} us = {gf[mt]['seconds_per_step'] / cb:.0f} |")
    return "\n".join(lines)


def getfem_mesh_table(mesh_file: str, schemes: list[str], T: float, dt: float) -> str:
    """Both codes on a GetFEM mesh file: GetFEM loads it (as the demo does) and exports
    it; contact-bench reads the export and runs `disc_drop` (2D) or `sphere_drop[degree=2]`
    (3D) on it, with the contact zone's mean edge length over p^2 as its Nitsche/penalty
    length (the scenes' `fem_nd.contact_length`)."""
    from contact_bench.api.registry import make_case

    results: dict[str, dict] = {}
    with tempfile.TemporaryDirectory() as tmp:
        exported = os.path.join(tmp, "mesh.npz")
        subprocess.run([GETFEM_PYTHON, os.path.abspath(__file__), "--getfem-export",
                        mesh_file, exported], check=True, stdout=subprocess.DEVNULL)
        mesh = read_getfem_mesh(exported)
        faces = int(np.load(exported)["contact_faces"])
        for contact in ("nitsche", "multipliers"):
            out = os.path.join(tmp, f"{contact}.json")
            subprocess.run([GETFEM_PYTHON, os.path.abspath(__file__), "--getfem-worker",
                            mesh_file, contact, out, json.dumps({"T": T, "dt": dt})],
                           check=True)
            with open(out) as f:
                results[f"GetFEM {'Nitsche' if contact == 'nitsche' else 'multipliers'}"] = \
                    json.load(f)
    d = mesh.dim()
    case = on_mesh(make_case("disc_drop" if d == 2 else "sphere_drop[degree=2]"), mesh)
    p = case.sparse_problem(case.nx, 1.0, "consistent")
    zone = p.contact.dofs // d
    C = mesh.facets if d == 2 else mesh.edges
    inside = C[:, np.all(np.isin(C, zone), axis=0)]  # the zone's edges (vertex dofs first)
    h = float(np.mean(np.linalg.norm(mesh.p[:, inside[0]] - mesh.p[:, inside[1]], axis=0)))
    # the scenes' convention for penalty and Nitsche (`fem_nd.contact_length`): that
    # element size over p^2
    h_contact = h / int(case.degree) ** 2
    refused = []
    for spec in schemes:
        try:
            results[f"contact-bench {spec}"] = bench_run(case, spec, case.nx, dt, T, h_contact)
        except ValueError as exc:  # e.g. a redistributed mass that is not SPD on this mesh
            refused.append(f"contact-bench {spec} refuses this mesh: {exc}.")
    body = "disc" if d == 2 else "ball"
    head = (f"GetFEM mesh `{os.path.basename(mesh_file)}`: {mesh.t.shape[1]} quadratic "
            f"{'triangles' if d == 2 else 'tetrahedra'}, {p.nfree} dofs (P2); contact zone: "
            f"{faces} faces in GetFEM (outward n_{'yz'[d - 2]} < -0.01), {zone.size} nodes "
            f"in contact-bench; contact-bench's h = {h:.3g} (the zone's mean edge length), "
            f"h_contact = h / p^2 = {h_contact:.3g}.\n\n")
    return head + table(results, dt, T, case.exact_energy, body) + "".join(
        "\n" + r for r in refused)


def getfem_available(python: str) -> str | None:
    """None if `python` imports getfem, else the reason."""
    try:
        out = subprocess.run([python, "-c", "import getfem"], capture_output=True, text=True,
                             timeout=120)
    except (OSError, subprocess.TimeoutExpired) as exc:
        return f"{python}: {exc}"
    return None if out.returncode == 0 else f"{python} cannot import getfem"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nx", type=int, default=5, help="element rings along the radius")
    ap.add_argument("--T", type=float, default=40.0)
    ap.add_argument("--dt", type=float, default=0.01)
    ap.add_argument("--schemes", nargs="+", default=["standard", "redistributed"],
                    help="contact-bench scheme specs")
    ap.add_argument("--out", default=None, help="also write the table to this file")
    ap.add_argument("--demo", choices=("disc", "1d"), default="disc",
                    help="the disc drop (2D) or the 1D demo on the clamped bar")
    ap.add_argument("--getfem-mesh", default=None, metavar="FILE",
                    help="run on this GetFEM mesh file instead (GetFEM's tests/meshes/"
                    "disc_P2_h*.mesh: the disc drop; sphere_with_quadratic_tetra_*.mesh: "
                    "the 3D sphere drop, contact-bench's sphere_drop)")
    args = ap.parse_args(argv)
    why = getfem_available(GETFEM_PYTHON)
    if why:
        print(f"skipped: GetFEM is absent ({why}; apt-get install python3-getfem)")
        return 0
    if args.getfem_mesh:
        if not os.path.isfile(args.getfem_mesh):
            print(f"skipped: no GetFEM mesh file {args.getfem_mesh} (GetFEM's tests/meshes/, "
                  "in its source tree, not in Debian's package)")
            return 0
        text = getfem_mesh_table(args.getfem_mesh, args.schemes, args.T, args.dt)
        print(text)
        if args.out:
            with open(args.out, "w") as f:
                f.write(text + "\n")
        return 0
    if args.demo == "1d":
        text = table_1d(GETFEM_PYTHON)
        print(text)
        if args.out:
            with open(args.out, "w") as f:
                f.write(text + "\n")
        return 0
    from contact_bench.api.registry import make_case

    case = make_case("disc_drop")
    results: dict[str, dict] = {}
    with tempfile.TemporaryDirectory() as tmp:
        mesh = os.path.join(tmp, "mesh.npz")
        export_mesh(case, args.nx, mesh)
        for contact in ("nitsche", "multipliers"):
            out = os.path.join(tmp, f"{contact}.json")
            cmd = [GETFEM_PYTHON, os.path.abspath(__file__), "--getfem-worker", mesh, contact,
                   out, json.dumps({"T": args.T, "dt": args.dt})]
            subprocess.run(cmd, check=True)
            with open(out) as f:
                results[f"GetFEM {'Nitsche theta=1' if contact == 'nitsche' else 'multipliers'}"
                        .replace(" theta=1", "")] = json.load(f)
    for spec in args.schemes:
        results[f"contact-bench {spec}"] = bench_run(case, spec, args.nx, args.dt, args.T)
    text = table(results, args.dt, args.T, case.exact_energy)
    print(text)
    if args.out:
        with open(args.out, "w") as f:
            f.write(text + "\n")
    return 0


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--getfem-worker":
        mesh_npz, contact, out, kw = sys.argv[2:6]
        res = getfem_run(mesh_npz, contact, **json.loads(kw))
        with open(out, "w") as f:
            json.dump(res, f)
        sys.exit(0)
    if len(sys.argv) > 1 and sys.argv[1] == "--getfem-export":
        getfem_export(sys.argv[2], sys.argv[3])
        sys.exit(0)
    if len(sys.argv) > 1 and sys.argv[1] == "--getfem-1d":
        with open(sys.argv[2], "w") as f:
            json.dump({str(mt): getfem_1d_run(mt) for mt in (0, 1)}, f)
        sys.exit(0)
    sys.exit(main())
