"""A converged reference for an impact scene: a refinement sequence at a fixed CFL and
Richardson extrapolation of its mesh-independent observables
(`contact_bench.exact.converged`), written as a versioned artefact.

    python benchmarks/converged_reference.py --case "disc_drop[degree=1]" \
        --scheme redistributed --cfl 0.1 --nx 10 --nx 20 --nx 40 --nx 80 --T 30 \
        --out results/references/disc_drop.json

Each level runs the scheme on the scene at nx with dt = cfl x hmin / c_max (the study's
definition of the CFL number) from t = 0 to T, sampling every step. The artefact (JSON)
holds the command, the scene, scheme, CFL, levels (nx, dt, dofs, seconds), every level's
observables, the extrapolated reference of each scalar with its estimated error and
observed order, and the force history's reference on its fixed grid with its estimated
relative l2 error; a Markdown summary is written next to it (.md). Files are written whole
at the end (a temporary file renamed), never half.
"""

from __future__ import annotations

import argparse
import json
import math
import platform
import shlex
import sys
import time
from dataclasses import replace
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.exact.converged import SCALARS, observables, richardson, richardson_history
from contact_bench.harness.io import write_text

VERSION = 1


def free_fall_start(problem, t0: float):
    """The problem's state at t0 of its free fall (a rigid vertical translation under
    the load's uniform acceleration: exact for the schemes whose free fall is exact,
    Newmark's average acceleration among them), as a new problem starting there."""
    if t0 == 0.0:
        return problem
    vertical = problem.vertical
    accel = float(problem.F @ vertical) / float(vertical @ (problem.M @ vertical))
    return replace(problem, U0=problem.U0 + 0.5 * accel * t0**2 * vertical,
                   V0=problem.V0 + accel * t0 * vertical)


def run_level(case, scheme, nx: int, dt: float, t0: float, T: float, stride: int,
              times: np.ndarray) -> dict:
    problem = free_fall_start(case.sparse_problem(nx, 1.0, scheme.mass_kind()), t0)
    steps = int(round((T - t0) / dt))
    start = time.perf_counter()
    traj = scheme.integrate(problem, dt, steps, stride)
    seconds = time.perf_counter() - start
    traj.t = traj.t + t0  # the run's clock from the scene's t = 0
    for key in ("first_contact_start", "first_contact_end"):
        if traj.extra.get(key) is not None:
            traj.extra[key] = float(traj.extra[key]) + t0
    obs = observables(problem, traj, dt, times)
    level = {"nx": nx, "dt": dt, "cfl": dt * problem.c_max / problem.hmin, "steps": steps,
             "stride": stride, "dofs": int(problem.U0.size), "seconds": round(seconds, 2)}
    level.update({q: obs[q] for q in SCALARS if q in obs})
    level["force_history"] = obs["force_history"].tolist()
    return level


def build(args: argparse.Namespace) -> dict:
    case = make_case(args.case)
    scheme = make_scheme(args.scheme)
    times = np.arange(args.grid_start, args.T + 1e-9, args.grid_step)
    levels = []
    nx0 = min(args.nx)
    for nx in sorted(args.nx):
        dt = args.dt0 * nx0 / nx
        stride = round(args.grid_step / dt)
        if not math.isclose(stride * dt, args.grid_step, rel_tol=1e-9) or not math.isclose(
                round(args.start / dt) * dt, args.start, rel_tol=1e-9, abs_tol=1e-12):
            raise SystemExit(f"dt = {dt:g} at nx {nx}: the grid step {args.grid_step:g} and "
                             f"the start {args.start:g} must be multiples of it")
        lv = run_level(case, scheme, nx, dt, args.start, args.T, stride, times)
        print(f"nx {nx}: dt {lv['dt']:.4g}, {lv['dofs']} dofs, {lv['seconds']} s, "
              + ", ".join(f"{q} {lv[q]:.8g}" for q in SCALARS if q in lv),
              file=sys.stderr, flush=True)
        levels.append(lv)
    scalars = {}
    for q in SCALARS:
        vals = [lv.get(q) for lv in levels]
        if any(v is None for v in vals):
            continue
        value, err, order = richardson(vals)
        scalars[q] = {"value": value, "error": err, "order": order,
                      "finest": vals[-1],
                      "finest_error": abs(vals[-1] - value)}
    n = min(len(lv["force_history"]) for lv in levels)
    ref_f, f_err, f_order = richardson_history([np.asarray(lv["force_history"][:n])
                                                for lv in levels])
    return {
        "version": VERSION,
        "command": "python benchmarks/converged_reference.py " + " ".join(
            shlex.quote(a) for a in sys.argv[1:]),
        "made": datetime.now(UTC).strftime("%Y-%m-%d %H:%M UTC"),
        "python": platform.python_version(),
        "case": case.spec, "scheme": scheme.spec, "cfl": levels[0]["cfl"],
        "dt0": args.dt0, "nx0": nx0, "start": args.start, "T": args.T,
        "levels": levels,
        "scalars": scalars,
        "force_history": {"times": times[:n].tolist(), "force": ref_f.tolist(),
                          "error": f_err, "order": f_order},
    }


def markdown(art: dict) -> str:
    lines = [f"# Converged reference: {art['case']}", "",
             f"Made by `{art['command']}` ({art['made']}, Python {art['python']}).", "",
             f"Scheme {art['scheme']}, CFL {art['cfl']:.4g} (dt c_max / hmin; dt = {art['dt0']:g} "
             f"x {art['nx0']} / nx), runs from the exact free fall at t = {art['start']:g} "
             f"to T = {art['T']}; levels (timings on a shared 2-core machine, perturbed by other "
             "jobs):", "", "| nx | dt | dofs | seconds |", "|---|---|---|---|"]
    lines += [f"| {lv['nx']} | {lv['dt']:.4g} | {lv['dofs']} | {lv['seconds']} |"
              for lv in art["levels"]]
    lines += ["", "| observable | " + " | ".join(f"nx {lv['nx']}" for lv in art["levels"])
              + " | reference | est. error | order | finest's error / ref error |",
              "|---" * (len(art["levels"]) + 5) + "|"]
    for q, s in art["scalars"].items():
        vals = " | ".join(f"{lv[q]:.8g}" for lv in art["levels"])
        ratio = s["finest_error"] / s["error"] if s["error"] else float("inf")
        order = "-" if s["order"] is None else f"{s['order']:.2f}"
        lines.append(f"| {q} | {vals} | {s['value']:.10g} | {s['error']:.2g} | {order} | "
                     f"{ratio:.3g} |")
    fh = art["force_history"]
    order = "-" if fh["order"] is None else f"{fh['order']:.2f}"
    lines += ["", f"Force history: {len(fh['times'])} times from {fh['times'][0]:g} to "
              f"{fh['times'][-1]:g}; estimated relative l2 error {fh['error']:.2g}, order "
              f"{order}.", ""]
    return "\n".join(lines)


def write_whole(path: Path, text: str) -> None:
    write_text(path, text)  # atomic; under results/: the source hash recorded


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--case", default="disc_drop[degree=1]")
    ap.add_argument("--scheme", default="redistributed")
    ap.add_argument("--dt0", type=float, default=0.025,
                    help="dt at the coarsest nx; dt = dt0 nx0 / nx (a fixed CFL)")
    ap.add_argument("--start", type=float, default=9.5,
                    help="start the runs at this time of the exact free fall")
    ap.add_argument("--nx", type=int, action="append", required=True)
    ap.add_argument("--T", type=float, default=29.0)
    ap.add_argument("--grid-start", type=float, default=10.0,
                    help="first time of the force history's grid")
    ap.add_argument("--grid-step", type=float, default=0.1)
    ap.add_argument("--out", type=Path, required=True, help="the artefact (.json)")
    args = ap.parse_args(argv)
    if len(args.nx) < 3:
        ap.error(f"--nx given {len(args.nx)} times: Richardson needs at least 3 levels")
    art = build(args)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    write_whole(args.out, json.dumps(art, indent=1) + "\n")
    write_whole(args.out.with_suffix(".md"), markdown(art))
    print(markdown(art))


if __name__ == "__main__":
    main()
