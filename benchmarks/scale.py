"""Scale: step time and peak memory against dofs, with their growth exponents.

    python benchmarks/scale.py                      # every size (up to ~5e5 dofs), results/scale.md
    python benchmarks/scale.py --max-dofs 2e4       # the sizes up to 2e4 dofs only
    python benchmarks/scale.py --scene ball_1e6     # the ball to 976,875 dofs, explicit lumped

Scenes and sizes (`CONFIGS`; the same ids as benchmarks/test_scale.py, the work fixed
by the id): `disc_drop[degree=2]` (2D, P2) at nx = 6 ... 144 rings (938 to 499,394 dofs)
and `sphere_drop` P1 (nx = 8, 16, 32) and P2 (nx = 4, 8, 16), 2,499 to 137,475 dofs (the
refined octahedron's nx is a power of two: its next size has 1.07e6 dofs). All
at lift = 1e-6, touching the plane from the first step, so every step solves its
contact subproblem. Schemes (`SCHEMES`, `KINDS`): implicit `redistributed` at the
scene's dt (0.01); explicit `redistributed[beta=0]` (central differences, massless
contact nodes) and, on P1 only (a P2 mass has negative row sums),
`taylor_flanagan[mass=lumped]`, at 0.9 x the declared limit on the mesh (the smaller of
that and the scene's dt). `ball_1e6`, run only when named (`OPT_IN`): the lattice ball
(`sphere_drop[ball=lattice]`, any nx) P1 at nx = 16, 32, 62 (18,051 to 976,875 dofs),
`taylor_flanagan[mass=lumped]` only: a run near a million dofs in 3D needs no factor
(an implicit one's Cholesky would not fit in memory, docs/scale.md).

Each configuration runs in a fresh process (`--one`, `measure`): JIT compilation on the
scene's smallest mesh its scheme runs first (outside, `warm_up`), then, from the
resident set size of that moment (`base`), the problem built and the stepper prepared
(`setup_s`, split by `build`: assembly, stability limit, stepper with its
factorisations), one warm-up call, `repeats` timed calls of `stepper.run(steps, steps)`
(the stepping alone: samples at the first and the last step), `step_s` = median call /
steps; then the solver floor in the same process (`floor`): one solve of the stepper's
factor as benchmarks/solver_floor.py times it, the ratios step / solve and set-up /
factorisation. Memory: the process's peak resident set size (`peak_MiB`, Linux VmHWM, reset at
`base` through
/proc/self/clear_refs) and what the run added to it (`growth_MiB` = peak - base:
problem, factors, operators and run; the interpreter and libraries excluded).

The growth exponents: least squares of log(setup_s), log(step_s) and log(growth_MiB)
against log(dofs), per scene and scheme, over the sizes that ran (two at least). A size that
fails (a mass refused on a coarse mesh, memory) is a row with its reason; the others go
on. The table, the exponents and the command go to results/scale.md (`--out`).
"""

from __future__ import annotations

import argparse
import ctypes
import gc
import json
import shlex
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "results" / "scale.md"
SCHEMES = {"implicit": "redistributed", "explicit": "redistributed[beta=0]",
           "explicit_lumped": "taylor_flanagan[mass=lumped]"}
#: the kinds run on each scene: a lumped mass only on P1 (P2 row sums are negative)
KINDS = {"disc_p2": ("implicit", "explicit"),
         "sphere_p1": ("implicit", "explicit", "explicit_lumped"),
         "sphere_p2": ("implicit", "explicit"),
         "ball_1e6": ("explicit_lumped",)}
#: scenes run only when named (`--scene`): the lattice ball up to 976,875 dofs, explicit
#: with the lumped mass (no factor), about 6 GB and a quarter of an hour
OPT_IN = ("ball_1e6",)
LIFT = 1e-6
#: (label, scene spec, nx, dofs): dofs as the mesh gives them (the id's work)
SIZES = (
    ("disc_p2", f"disc_drop[degree=2,lift={LIFT:g}]", 6, 938),
    ("disc_p2", f"disc_drop[degree=2,lift={LIFT:g}]", 12, 3_602),
    ("disc_p2", f"disc_drop[degree=2,lift={LIFT:g}]", 24, 14_114),
    ("disc_p2", f"disc_drop[degree=2,lift={LIFT:g}]", 48, 55_874),
    ("disc_p2", f"disc_drop[degree=2,lift={LIFT:g}]", 96, 222_338),
    ("disc_p2", f"disc_drop[degree=2,lift={LIFT:g}]", 144, 499_394),
    ("sphere_p1", f"sphere_drop[degree=1,lift={LIFT:g}]", 8, 2_499),
    ("sphere_p1", f"sphere_drop[degree=1,lift={LIFT:g}]", 16, 18_051),
    ("sphere_p1", f"sphere_drop[degree=1,lift={LIFT:g}]", 32, 137_475),
    ("sphere_p2", f"sphere_drop[degree=2,lift={LIFT:g}]", 4, 2_499),
    ("sphere_p2", f"sphere_drop[degree=2,lift={LIFT:g}]", 8, 18_051),
    ("sphere_p2", f"sphere_drop[degree=2,lift={LIFT:g}]", 16, 137_475),
    ("ball_1e6", f"sphere_drop[degree=1,ball=lattice,lift={LIFT:g}]", 16, 18_051),
    ("ball_1e6", f"sphere_drop[degree=1,ball=lattice,lift={LIFT:g}]", 32, 137_475),
    ("ball_1e6", f"sphere_drop[degree=1,ball=lattice,lift={LIFT:g}]", 62, 976_875),
)


def steps_for(kind: str, dofs: int) -> int:
    """The fixed number of steps of a configuration: about 2e6 dof-steps a call, within
    5 ... 200 steps (implicit and explicit alike: today's explicit paths carry dense
    response matrices, docs/sparse.md, and cost as much as an implicit step)."""
    return max(5, min(200, round(2e6 / dofs)))


def configs(max_dofs: float = float("inf"), labels: Any = None) -> list[dict[str, Any]]:
    """Every (size, scheme) up to max_dofs (of the scenes `labels`, default all but
    `OPT_IN`), with its id `label-nxN-dofsD-kind-stepsS`."""
    out = []
    for label, scene, nx, dofs in SIZES:
        if dofs > max_dofs or (label not in labels if labels else label in OPT_IN):
            continue
        for kind in KINDS[label]:
            scheme = SCHEMES[kind]
            steps = steps_for(kind, dofs)
            out.append({"id": f"{label}-nx{nx}-dofs{dofs}-{kind}-steps{steps}",
                        "label": label, "scene": scene, "nx": nx, "dofs_id": dofs,
                        "kind": kind, "scheme": scheme, "steps": steps})
    return out


def warm_up(cfg: dict[str, Any]) -> None:
    """Compile the configuration's kernels (JIT outside the measure) on the scene's
    smallest mesh that its scheme runs, up to the configuration's own."""
    meshes = sorted(nx for lab, _, nx, _ in SIZES if lab == cfg["label"] and nx <= cfg["nx"])
    for i, nx in enumerate(meshes):
        try:
            stepper, _, _ = build(cfg, nx)
        except Exception:  # a mesh refused (e.g. a mass not SPD): the next one
            if i == len(meshes) - 1:
                raise
            continue
        stepper.run(2, 2)
        return


def forget() -> None:
    """Empty the process's caches of meshes, bodies and problems (`Kept.clear_all`):
    the warm-up's mesh may be the configuration's own, whose set-up is then measured
    whole."""
    from contact_bench.api.kept import Kept

    Kept.clear_all()


# ------------------------------------------------------------------ memory


def rss_mib(field: str = "VmRSS") -> float:
    """This process's resident set size (VmRSS) or its peak (VmHWM), in MiB (Linux)."""
    with open("/proc/self/status", encoding="ascii") as fh:
        for line in fh:
            if line.startswith(field + ":"):
                return int(line.split()[1]) / 1024.0
    raise OSError(f"{field} not in /proc/self/status")


def reset_peak() -> float:
    """Free what can be freed, reset the peak RSS to the current RSS (Linux >= 4.0:
    /proc/self/clear_refs, 5) and return it, in MiB."""
    gc.collect()
    try:
        ctypes.CDLL("libc.so.6").malloc_trim(0)
    except OSError:
        pass
    with open("/proc/self/clear_refs", "w", encoding="ascii") as fh:
        fh.write("5")
    return rss_mib()


# ------------------------------------------------------------------ one measurement


def build(cfg: dict[str, Any], nx: int | None = None,
          split: dict[str, float] | None = None) -> tuple[Any, int, float]:
    """The prepared stepper of a configuration (at nx, default the configuration's), the
    problem's dofs and the time step. `split` (given): filled with the set-up's parts in
    seconds: `assembly_s` (the problem: mesh, K, M, contact zone), `limit_s` (an
    explicit scheme's stability limit on the mesh, an eigenvalue), `prepare_s` (the
    stepper) and, inside it, `factor_s` and `contact_s` (its factorisations and contact
    operators, `contact_bench.core.timers`)."""
    from contact_bench.api.registry import make_case, make_scheme
    from contact_bench.core.timers import recording
    from contact_bench.harness.runner import declared_limit, problem_for

    case, scheme = make_case(cfg["scene"]), make_scheme(cfg["scheme"])
    t0 = time.perf_counter()
    problem = problem_for(case, scheme, cfg["nx"] if nx is None else nx)
    t1 = time.perf_counter()
    dt = float(case.dt)
    if cfg["kind"].startswith("explicit"):
        limit = declared_limit(case, scheme, problem)
        if limit is not None:
            dt = min(dt, 0.9 * limit)
    t2 = time.perf_counter()
    with recording() as phases:
        stepper = scheme.prepare(problem, dt)
    t3 = time.perf_counter()
    if split is not None:
        split.update(assembly_s=t1 - t0, limit_s=t2 - t1, prepare_s=t3 - t2,
                     factor_s=phases.get("factor", 0.0), contact_s=phases.get("contact", 0.0))
    return stepper, int(problem.U0.size), dt


def floor(stepper: Any, step_s: float, setup_s: float,
          factor_s: float) -> dict[str, float]:
    """The solver floor beside a size, in this process: one solve of the stepper's
    factor (`solve_seconds` of benchmarks/solver_floor.py) and the ratios step / solve
    and set-up / factorisation; NaN for a stepper without a factor (a lumped mass)."""
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import solver_floor

    fac = getattr(stepper, "factor", None)
    solve = solver_floor.solve_seconds(fac) if fac is not None else float("nan")
    return {"solve_s": solve, "step_per_solve": step_s / solve,
            "setup_per_factor": setup_s / factor_s if factor_s > 0 else float("nan")}


def measure(cfg: dict[str, Any], repeats: int = 3) -> dict[str, Any]:
    """One configuration in this process (module docstring); a failure is a row with
    status 'error' and its reason."""
    row: dict[str, Any] = {k: cfg[k] for k in ("id", "label", "scene", "nx", "kind",
                                               "scheme", "steps")}
    try:
        warm_up(cfg)  # JIT outside
        forget()
        base = reset_peak()
        split: dict[str, float] = {}
        start = time.perf_counter()
        stepper, dofs, dt = build(cfg, split=split)
        setup = time.perf_counter() - start
        steps = int(cfg["steps"])
        stepper.run(steps, steps)  # warm-up call
        times = []
        for _ in range(max(1, repeats)):
            t0 = time.perf_counter()
            stepper.run(steps, steps)
            times.append(time.perf_counter() - t0)
        peak = rss_mib("VmHWM")
        step = statistics.median(times) / steps
        row.update(dofs=dofs, dt=dt, setup_s=setup, **split, step_s=step,
                   repeats=len(times), peak_MiB=peak, growth_MiB=peak - base,
                   **floor(stepper, step, setup, split["factor_s"]), status="ok", notes="")
    except Exception as exc:  # noqa: BLE001 - a failing size is a row, the others go on
        row.update(status="error", notes=" ".join(f"{type(exc).__name__}: {exc}".split()))
    return row


def measure_fresh(cfg: dict[str, Any], repeats: int) -> dict[str, Any]:
    """`measure` in a fresh Python process (its own JIT, heap and peak)."""
    proc = subprocess.run([sys.executable, __file__, "--one", json.dumps(cfg), "--repeats",
                           str(repeats)], cwd=ROOT, capture_output=True, text=True)
    lines = proc.stdout.strip().splitlines()
    if proc.returncode != 0 or not lines:
        why = (proc.stderr.strip().splitlines() or [f"exit {proc.returncode}"])[-1]
        return {**{k: cfg[k] for k in ("id", "label", "scene", "nx", "kind", "scheme",
                                        "steps")},
                "status": "error", "notes": f"process failed: {why}"}
    return json.loads(lines[-1])


# ------------------------------------------------------------------ table and fit


#: the growth exponents: column -> its name in the exponents' table
GROWTH = {"setup_s": "setup_exponent", "step_s": "step_exponent",
          "growth_MiB": "memory_exponent"}


def exponents(df: Any) -> Any:
    """Least-squares slopes of log(setup_s), log(step_s) and log(growth_MiB) against
    log(dofs), per scene label and kind, over the ok rows (NaN below two sizes)."""
    import numpy as np
    import pandas as pd

    rows = []
    ok = df[df["status"] == "ok"] if "status" in df else df.iloc[0:0]
    for (label, kind), g in ok.groupby(["label", "kind"], sort=False):
        rec = {"label": label, "kind": kind, "scheme": g["scheme"].iloc[0], "sizes": len(g),
               "dofs_min": int(g["dofs"].min()), "dofs_max": int(g["dofs"].max())}
        for col, name in GROWTH.items():
            y = g[col].to_numpy(float)
            x = g["dofs"].to_numpy(float)
            keep = np.isfinite(y) & (y > 0)
            rec[name] = (float(np.polyfit(np.log(x[keep]), np.log(y[keep]), 1)[0])
                         if keep.sum() >= 2 else float("nan"))
        rows.append(rec)
    return pd.DataFrame(rows, columns=["label", "kind", "scheme", "sizes", "dofs_min",
                                       "dofs_max", *GROWTH.values()])


def report(rows: list[dict[str, Any]], command: str, max_dofs: float) -> str:
    """results/scale.md: the command, the table, the exponents."""
    import pandas as pd

    sys.path.insert(0, str(ROOT))
    from contact_bench.harness.environment import provenance

    df = pd.DataFrame(rows)
    for col in ("step_s", "solve_s"):
        if col in df:
            df[col.replace("_s", "_ms")] = 1e3 * df[col]
    cols = [c for c in ("label", "nx", "dofs", "kind", "scheme", "steps", "assembly_s",
                        "limit_s", "prepare_s", "setup_s", "factor_s", "step_ms",
                        "solve_ms", "step_per_solve", "setup_per_factor", "peak_MiB",
                        "growth_MiB", "status", "notes") if c in df]
    table = df[cols]
    fit = exponents(df)
    every = {label for label in KINDS if label not in OPT_IN}
    full = max_dofs >= max(d for *_, d in SIZES) and set(df["label"]) >= every
    sizes = ("every size" if max_dofs >= max(d for *_, d in SIZES)
             else f"the sizes up to {max_dofs:g} dofs")
    scope = ("every size" if full else
             f"{sizes} of {', '.join(dict.fromkeys(df['label']))} "
             "only (a partial run: the full one is `python benchmarks/scale.py`)")
    prov = provenance(["(benchmarks/scale.py)"]).split("; ", 1)[1]
    return "\n".join([
        "# Scale: step time and memory against dofs", "",
        f"Made by `{command}` ({scope}); {prov}. What is measured: "
        "benchmarks/scale.py's docstring (docs/benchmarks.md).", "",
        "Growth exponents (least squares on log-log, over the sizes that ran):", "",
        fit.to_markdown(index=False, floatfmt=".3g"), "",
        "Every configuration (a fresh process each; `setup_s`: problem and stepper, "
        "the sum of `assembly_s` (the problem), `limit_s` (an explicit scheme's stability "
        "limit) and `prepare_s` (the stepper; its factorisations `factor_s`); `step_ms`: "
        "one step, median of the timed calls; the solver floor in the same process: "
        "`solve_ms`, one solve of the stepper's factor, `step_per_solve` and "
        "`setup_per_factor` (empty without a factor); `peak_MiB`: the process's peak "
        "RSS, `growth_MiB`: what the run added to it):", "",
        table.to_markdown(index=False, floatfmt=".4g"), ""])


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--max-dofs", type=float, default=float("inf"),
                   help="largest size run, in dofs (default: every size, up to ~5e5)")
    p.add_argument("--repeats", type=int, default=3, help="timed calls per size (3)")
    p.add_argument("--out", default=str(OUT), help="the report (default results/scale.md)")
    p.add_argument("--same-process", action="store_true",
                   help="every size in this process (quick check; memory then less clean)")
    p.add_argument("--scene", action="append", choices=list(KINDS),
                   help="only these scenes (repeatable; default: all but "
                   f"{', '.join(OPT_IN)})")
    p.add_argument("--one", help=argparse.SUPPRESS)  # a fresh process's configuration
    args = p.parse_args(argv)
    if args.repeats < 1:
        p.error(f"--repeats must be >= 1, got {args.repeats}")
    if not args.max_dofs > 0:
        p.error(f"--max-dofs must be > 0, got {args.max_dofs:g}")
    sys.path.insert(0, str(ROOT))
    if args.one:
        print(json.dumps(measure(json.loads(args.one), args.repeats)))
        return 0
    todo = configs(args.max_dofs, args.scene)
    if not todo:
        p.error(f"--max-dofs {args.max_dofs:g}: no size is that small (the smallest has "
                f"{min(d for *_, d in SIZES)} dofs)")
    rows = []
    for cfg in todo:
        row = measure(cfg, args.repeats) if args.same_process else measure_fresh(
            cfg, args.repeats)
        rows.append(row)
        shown = (f"{row['dofs']:>8} dofs  step {1e3 * row['step_s']:10.4g} ms  growth "
                 f"{row['growth_MiB']:8.1f} MiB" if row["status"] == "ok" else row["notes"])
        print(f"{cfg['id']:<48} {shown}", flush=True)
    command = " ".join(["python benchmarks/scale.py", *map(shlex.quote, argv)])
    text = report(rows, command, args.max_dofs)
    from contact_bench.harness.io import write_text

    write_text(args.out, text)
    print(exponents(__import__("pandas").DataFrame(rows)).to_string(index=False))
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
