"""Run (case, scheme, nx, dt, T, stride) and tabulate one metrics row per run.

The harness reads only what plugins declare: the case's reference and the quantities
it provides, the scheme's traits, stability limit and `cannot_run`. What a scene does
not provide is left empty (NaN) and the row's `notes` say why.

A table's columns (`table_columns`): `BASE_COLUMNS`, which every row has, in their order;
then, sorted by name, the relative errors `err_<q>` of the quantities its scenes declare
(`Case.reference_quantities`, `quantity_columns`) and any other column a row carries.

A run prepares the scheme's stepper once (`Scheme.prepare`: factorisations, Delassus
operators, contact laws) and steps it several times: a warm-up, the timing repeats and the
recorded run. Three times per run (`TIMING_COLUMNS`), JIT compilation and the error norms
excluded:
- `setup_s`: the preparation (`Scheme.prepare`), once; of it, `setup_factor_s` in sparse
  factorisations and `setup_contact_s` in the contact operators (Delassus matrix,
  response; `contact_bench.core.timers` phases, exclusive: a factor made for the contact
  operators counts as a factor), the rest the scheme's own work; `assembly_s`: building
  the problem it steps (mesh, matrices, mass variant, contact set), shared by the runs
  of a table that read the same problem (each row shows what it cost once);
- `run_s`: the recorded run itself, recording every `stride`-th step as the norms need
  (`wall_s` is the same value under its former name, so `wall_s / (nx * steps)` still
  reads as ns per dof-step, recording included);
- `step_s`: the stepping alone, the same stepper with samples only where the scheme needs
  them (stride = steps: the first and the last), the minimum of up to `STEP_REPEATS`
  calls after a warm-up call (`step_time`). Work-precision compares it. A run whose
  stepping a short probe predicts over `STEP_BUDGET_S` is stepped once: its `step_s` is
  its `run_s` (recording included; the row's notes say so), so that a long run's wall
  time stays near set-up + stepping instead of twice the stepping.
A scene's declared numerical reference (`Case.reference_run`) is computed once and kept
on disk (`contact_bench.harness.reference_cache`), before the run: `ref_s` is the time
this run spent getting it (computing it, or reading it back: `ref_from_cache`),
`ref_compute_s` what computing it took; neither is in `run_s`.
"""

from __future__ import annotations

import dataclasses
import math
import time
import traceback
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np
from numba.core import event as numba_event

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.kept import Kept, case_key
from contact_bench.api.params import format_value
from contact_bench.api.plugin import Case, Exact, Scheme, Stepper, Trajectory
from contact_bench.api.problem import BarProblem, banded, discretise
from contact_bench.api.registry import make_case, make_scheme
from contact_bench.api.sparse import SPARSE, AxisView
from contact_bench.core.errors import BenchError, shown_repr
from contact_bench.core.timers import recording
from contact_bench.harness import metrics
from contact_bench.harness.footprint import check_fits
from contact_bench.harness.impacts import impact_metrics, impact_table
from contact_bench.harness.metrics import (
    ERROR_COLUMNS,
    NEEDS,
    energy_metrics,
    error_metrics,
    penetration,
)
from contact_bench.harness.quantities import first_contact_errors
from contact_bench.harness.reference_cache import reference_samples
from contact_bench.harness.time_error import time_errors

if TYPE_CHECKING:  # pandas is imported when a table is made, not while runs step
    import pandas as pd

#: the columns every row has, in this order; a table adds after them the columns its
#: rows declare or carry (`table_columns`: the scenes' `err_<q>`, sorted by name)
BASE_COLUMNS = (
    "case", "scheme", "nx", "dt", "T", "steps", *ERROR_COLUMNS,
    "energy_initial", "energy_final", "energy_drift_max", "penetration_max", "step_s",
    "setup_s", "setup_factor_s", "setup_contact_s", "assembly_s", "run_s", "wall_s",
    "status", "notes", "stride", "grading", "blowup_time",
    "reference",
    # many contact dofs (sparse problems; empty for the 1D bar)
    "chatter", "first_contact_start", "first_contact_end", "peak_contact_force",
    "symmetry_defect",
    # the work of the tangential contact forces (problems with friction; empty without)
    "friction_work",
    # impact by impact (`contact_bench.harness.impacts`; problems with a vertical translation)
    "impacts", "rebound_ratio", "energy_after_first_impact", "impulse_residual",
)
#: the columns that vary from one execution of the same run to the next (module docstring)
TIMING_COLUMNS = ("step_s", "setup_s", "setup_factor_s", "setup_contact_s", "assembly_s",
                  "run_s", "wall_s", "ref_s", "ref_compute_s", "time_ref_compute_s",
                  "ref_from_cache")
#: `step_s` is the minimum of at most this many timed stepping calls (after a warm-up) ...
STEP_REPEATS = 3
#: ... and no more once they have taken this long (at least one timed call)
STEP_BUDGET_S = 1.0
#: a run whose stepping a probe predicts over `STEP_BUDGET_S` is stepped once and reports
#: its recorded call as its `step_s` (no second call for the stepping alone): the recording
#: is then part of `step_s`, a small part of an implicit step, so the run's wall time stays
#: near set-up + stepping; runs sampled at least this sparsely record next to nothing
LONG_RUN_STRIDE = 10

#: what this process has warmed up (run once outside the timings, so that JIT
#: compilation stays out of them): ("stepper", scheme type, mass, implicit, form) per
#: kernel, ("norms",) for the error norms, ("reference", type) per reference type
_warmed: set[tuple] = set()
#: a plan's semi-discrete problem dropped after the checks, rebuilt when it runs
_REBUILD: Any = object()
#: semi-discrete problems a table keeps from its checks to its runs, in bytes (the
#: first plan's is always kept); the others are assembled again when they run
KEEP_SEMI_BYTES = 64 * 2**20


@dataclass
class Run:
    """One finished run: its metrics row and, unless it did not start, its trajectory.

    `problem`: the problem the scheme stepped (the one form: a body's `SparseProblem`,
    the bar's `BarProblem`); `semi` the form the error norms read (the bar's
    `Semidiscrete`, a body's problem). `norm_s`: the time spent on the error norms
    (`contact_bench.harness.metrics.error_metrics`, JIT compilation excluded), None when
    there were none; compare with row["run_s"].
    """

    row: dict[str, Any]
    trajectory: Trajectory | None = None
    problem: Any = None
    norm_s: float | None = None
    #: the formatted traceback of an 'error' row (`contact-bench run --traceback`)
    traceback: str | None = None

    @property
    def semi(self) -> Any:
        return None if self.problem is None else (banded(self.problem) or self.problem)

    def without_samples(self) -> Run:
        """The same run without what grows with the mesh: the semi-discrete problem and
        the sampled fields U, V (left with no columns); t, contact_u, stress and energy
        stay (what the figures use)."""
        tr = self.trajectory
        if tr is not None:
            tr = dataclasses.replace(tr, U=np.empty((tr.t.size, 0)), V=np.empty((tr.t.size, 0)))
        return Run(self.row, tr, None, self.norm_s, self.traceback)


#: references kept for the next runs: at most this many, and at most this many bytes
#: (counting those that tell their size, `nbytes`; a larger one is not kept)
KEEP_REFERENCES = 4
KEEP_REFERENCE_BYTES = 128 * 2**20
#: the exact references of the last runs (`reference`), by scene and final time
REFERENCES: Kept[Exact | None] = Kept(
    "exact references", max_items=KEEP_REFERENCES, max_bytes=KEEP_REFERENCE_BYTES,
    size=lambda exact: int(getattr(exact, "nbytes", 0) or 0))


def reference(case: Case, T: float) -> Exact | None:
    """`case.exact(T)`, kept for the next runs: the schemes of a table share it.

    Keyed on the scene (`contact_bench.api.kept.case_key`: class, spec, attributes, data
    files) and on T, so a changed case or time builds a new one (an explicit scheme's
    lowered dt gives another T). A few are kept (`REFERENCES`: `KEEP_REFERENCES`,
    `KEEP_REFERENCE_BYTES`), so memory does not grow with a table.
    """
    return REFERENCES.get_or_build((case_key(case), float(T)), lambda: case.exact(T))


def _num(x: float) -> str:
    """A number for a message: as typed when short (1e-320), else `:.6g`."""
    text = format_value(float(x))
    return text if len(text) <= 12 else f"{x:.6g}"


def _many(x: float) -> str:
    return f"{x:.3g}" if math.isfinite(x) else "more than 1e308"


def _int_text(n: int) -> str:
    """An integer for a message: whole up to 12 digits, else like 1.23e+300."""
    if abs(n) < 10**12:
        return str(n)
    if abs(n) < 10**308:
        return f"{float(n):.3g}"
    s = str(abs(n))  # beyond a float's range
    return f"{'-' if n < 0 else ''}{s[0]}.{s[1:3]}e+{len(s) - 1}"


def _check_positive(name: str, value: Any) -> float:
    if isinstance(value, bool):
        raise BenchError(f"{name} must be a number > 0, got {value!r}")
    try:
        value = float(value)
    except (TypeError, ValueError, OverflowError):
        raise BenchError(f"{name} must be a number > 0, got {shown_repr(value)}") from None
    if not (math.isfinite(value) and value > 0):
        raise BenchError(f"{name} must be finite and > 0, got {value!r}")
    if name in {"dt", "T"} and value < MIN_TIME:
        raise BenchError(f"{name} must be >= {MIN_TIME:g} (dt^2 must not underflow), "
                         f"got {_num(value)}")
    return value


#: smallest dt and T: kernels divide by dt^2, which must stay a normal float
MIN_TIME = 1e-150


#: smallest and largest number of elements: below 2 some schemes have no free node
#: besides the contact node; above, the mesh alone would not fit the memory budget
MIN_NX = 2
MAX_NX = 20_000_000


def _check_nx(nx: Any) -> int:
    allowed = f"an integer in [{MIN_NX}, {MAX_NX:.0e}]".replace("e+0", "e")
    if isinstance(nx, bool) or not isinstance(nx, int | np.integer | str | float):
        raise BenchError(f"nx must be {allowed}, got {shown_repr(nx)}")
    try:
        value = int(nx) if not isinstance(nx, str) else int(nx.strip())
    except (ValueError, OverflowError):
        raise BenchError(f"nx must be {allowed}, got {shown_repr(nx)}") from None
    if isinstance(nx, float) and value != nx:
        raise BenchError(f"nx must be {allowed}, got {nx!r}")
    if not MIN_NX <= value <= MAX_NX:
        raise BenchError(f"nx must be {allowed}, got {_int_text(value)}")
    return value


def check_task_inputs(nx: Any = None, dt: Any = None, T: Any = None, cfl: Any = None,
                      stride: Any = None, grading: Any = 1.0) -> None:
    """Check the numeric inputs of a run before anything runs (one-line BenchError)."""
    if nx is not None:
        _check_nx(nx)
    for name, value in (("dt", dt), ("T", T), ("cfl", cfl)):
        if value is not None:
            _check_positive(name, value)
    if stride is not None:
        _check_stride(stride)
    _check_grading(grading)


def _check_stride(stride: Any) -> int:
    ok = (not isinstance(stride, bool) and isinstance(stride, int | np.integer | float)
          and stride == stride and abs(stride) != math.inf and int(stride) == stride
          and stride >= 1)
    if not ok:
        text = _int_text(stride) if isinstance(stride, int) else shown_repr(stride)
        raise BenchError(f"stride must be an integer >= 1, got {text}")
    return int(stride)


def _check_grading(grading: Any) -> float:
    try:
        value = float(grading)
    except (TypeError, ValueError):
        raise BenchError(f"grading must be a number >= 1, got {shown_repr(grading)}") from None
    if not (math.isfinite(value) and value >= 1.0):
        raise BenchError(f"grading must be a finite number >= 1, got {grading!r}")
    return value


#: largest sample buffers a run may allocate (U and V, float64), in bytes
MAX_SAMPLE_BYTES = 4 * 2**30
#: most time steps of one run (a smaller dt is refused up front, not run for days)
MAX_STEPS = 10**9
#: longest run, in wave transits of the scene (T c_max / size, `Case.size`: a bar's
#: length, a body's declared characteristic length): this bounds the cost of a
#: reference (characteristics, numerical) as the sample memory bounds a run's
MAX_TRANSITS = 1e5
#: the graded mesh's smallest element, as a fraction of the bar: below, the system
#: matrices lose positive definiteness in round-off
MIN_ELEMENT_FRACTION = 1e-10


def check_mesh_grading(nx: int, grading: float) -> None:
    """The smallest element of a graded mesh is L (1/nx)^grading: refuse it too small."""
    if grading == 1.0:
        return
    smallest = grading * -math.log10(nx)  # log10 of h_min / L
    if smallest < math.log10(MIN_ELEMENT_FRACTION):
        top = math.log10(MIN_ELEMENT_FRACTION) / -math.log10(nx)
        raise BenchError(
            f"grading = {_num(grading)} at nx = {nx} makes the smallest element "
            f"1e{smallest:.0f} of the bar's length; allowed: at least "
            f"{MIN_ELEMENT_FRACTION:g} (grading <= {math.floor(top * 100) / 100:g} at this nx)")


@dataclass
class _Plan:
    """A checked configuration, ready to integrate (or a finished 'not applicable' row)."""

    case: Case
    scheme: Scheme
    row: dict[str, Any]
    notes: list[str]
    semi: Any = None
    dt: float = 0.0
    steps: int = 0
    stride: int = 1
    T_run: float = 0.0
    #: a later run of the table has the same case, mesh and sample times: the error
    #: norms keep what they can share with it (`contact_bench.harness.metrics.error_metrics`'s keep)
    shared: bool = True
    #: > 1: the time error against the same scheme at dt / time_error
    #: (`contact_bench.harness.time_error`)
    time_error: int = 0

    def grid(self) -> tuple | None:
        """What the error norms of two runs share when it is equal: the case (one
        object per table), the mesh and the sample times; None for a run without."""
        if self.semi is None:
            return None
        r = self.row
        return (id(self.case), r["nx"], r["grading"], self.dt, self.steps, self.stride)


def _prepare(case: Case, scheme: Scheme, nx: Any, dt: Any, T: Any, stride: Any,
             grading: Any, allow_unstable: bool, strict: bool, problem: Any = None) -> _Plan:
    """Every check of run_one that needs no time stepping; bad input raises BenchError.
    `problem`: the scene's problem at (nx, grading) with the scheme's mass, when the
    caller has built it (`problem_for`); None: built here."""
    nx = _check_nx(case.nx if nx is None else nx)
    T = _check_positive("T", case.T if T is None else T)
    dt_given = dt is not None
    dt = _check_positive("dt", case.dt if dt is None else dt)
    stride_given = stride is not None
    stride = _check_stride(case.stride if stride is None else stride)  # scene's default
    grading = _check_grading(grading)
    row: dict[str, Any] = dict.fromkeys((*BASE_COLUMNS, *quantity_columns(case)))
    row.update(case=case.spec, scheme=scheme.spec, nx=nx, T=T, stride=stride,
               grading=grading, reference=case.reference or "none")
    notes: list[str] = []
    reason = scheme.cannot_run(case) or case.cannot_run(scheme)
    if reason:
        if strict:
            raise BenchError(f"scheme {scheme.spec} cannot run case {case.spec}: {reason}")
        row.update(dt=dt, status="not applicable", notes=reason)
        return _Plan(case, scheme, row, notes)

    check_mesh_grading(nx, grading)
    if dt > T and dt_given:
        raise BenchError(f"dt = {_num(dt)} is larger than T = {_num(T)}; allowed: dt <= T")
    if dt > T:  # a short run of a scene: its default dt is one step to T
        notes.append(f"dt lowered to T (the default {_num(dt)} is larger)")
        dt = T
    if T / dt > MAX_STEPS:
        raise BenchError(f"dt = {_num(dt)} with T = {_num(T)} makes {_many(T / dt)} steps; "
                         f"allowed: at most {MAX_STEPS:.0e} steps (a larger dt or a smaller T)")
    semi = problem_for(case, scheme, nx, grading) if problem is None else problem
    length = _check_size(case)
    transits = T * semi.c_max / length
    if not transits <= MAX_TRANSITS:
        raise BenchError(f"T = {_num(T)} is {transits:.3g} wave transits of {case.spec}; "
                         f"allowed: at most {MAX_TRANSITS:g} (T <= "
                         f"{_num(MAX_TRANSITS * length / semi.c_max)})")
    limit = declared_limit(case, scheme, semi)
    lowered = ""
    if limit is not None and dt > limit * (1 + 1e-12):
        if dt_given and not allow_unstable:
            raise BenchError(
                f"dt = {_num(dt)} is above the stability limit {limit:.6g} of {scheme.spec} "
                f"at nx = {nx} (pass --allow-unstable to run it anyway)")
        if dt_given:
            notes.append(f"dt above the stability limit {limit:.4g} (--allow-unstable)")
        else:  # the case's default dt is too large for this explicit scheme
            dt = 0.9 * limit
            notes.append(f"dt lowered to 0.9 x the stability limit {limit:.4g}")
            lowered = " (lowered to 0.9 x its stability limit)"
    if T / dt > MAX_STEPS:  # the lowered dt of an explicit scheme
        raise BenchError(f"{scheme.spec} on {case.spec}: dt = {_num(dt)}{lowered} with "
                         f"T = {_num(T)} makes {_many(T / dt)} steps; "
                         f"allowed: at most {MAX_STEPS:.0e} steps")
    steps = max(1, math.ceil(T / dt - 1e-9))
    if stride > steps and not stride_given:
        stride = steps  # a short run of a long scene: its default stride is too coarse
        row["stride"] = stride
    if stride > steps:
        raise BenchError(f"stride = {_int_text(stride)} is larger than the number of steps "
                         f"({steps})")
    samples = steps // stride + 2
    if 16.0 * samples * semi.nfree > MAX_SAMPLE_BYTES:
        need = math.ceil(16.0 * steps * semi.nfree / MAX_SAMPLE_BYTES)
        fix = (f"a larger dt or --stride >= {_int_text(need)}" if need <= steps / 2
               else "a larger dt")
        raise BenchError(
            f"{scheme.spec} on {case.spec}: dt = {_num(dt)}{lowered} with T = {_num(T)} and "
            f"nx = {nx} keeps {float(samples):.3g} samples of {semi.nfree} values (over "
            f"{MAX_SAMPLE_BYTES / 2**30:g} GiB); allowed: {fix}")
    T_run = steps * dt
    row.update(dt=dt, T=T_run, steps=steps)
    return _Plan(case, scheme, row, notes, semi, dt, steps, stride, T_run)


def check_run(case: Case, scheme: Scheme, nx: Any, dt: Any, T: Any, stride: Any,
              grading: Any = 1.0, allow_unstable: bool = False, problem: Any = None) -> None:
    """Every check of `run_one` that needs no time stepping (a sweep's inputs are checked
    so before its first run); bad input raises BenchError. `problem`: as `run_one`'s."""
    check_mesh_grading(_check_nx(nx), _check_grading(grading))
    _prepare(case, scheme, nx, dt, T, stride, grading, allow_unstable, False, problem)


def _discretise(case: Case, scheme: Scheme, nx: int, grading: float) -> Any:
    """The problem (one form for every scene) with the scheme's mass variant: a body's
    `SparseProblem`, or the bar's `BarProblem` (its banded form inside), with the seconds
    its building took as its `assembly_s` (the bar's, built here, set on it; a body's, a
    copy with the field set: the scene may keep the problem it built)."""
    start = time.perf_counter()
    problem = _build(case, scheme, nx, grading)
    seconds = time.perf_counter() - start
    if isinstance(problem, BarProblem):
        problem.assembly_s = seconds
        return problem
    return dataclasses.replace(problem, assembly_s=seconds)


def _build(case: Case, scheme: Scheme, nx: int, grading: float) -> Any:
    if case.form == SPARSE:
        check_fits(case, scheme, nx)  # a size that cannot fit: refused before assembly
        try:
            problem = case.sparse_problem(nx, grading, scheme.mass_kind())
            problem.check()
            return problem
        except ValueError as exc:
            raise BenchError(f"case {case.spec}: {exc}") from None
    semi = discretise(case, mesh_nodes(_check_length(case), nx, grading), scheme.mass_kind())
    return BarProblem(semi, scheme.mass_kind())


#: the problems this process built, by scene (`contact_bench.api.kept.case_key`), nx,
#: grading and mass variant: a sweep task's checks, run and timing pass read one problem,
#: and so do the schemes of a table that share a mass variant. Bounded like the problems
#: a table keeps (`KEEP_SEMI_BYTES`): a larger one is built again where it is asked again.
PROBLEMS: Kept[Any] = Kept("problems", max_items=8, max_bytes=KEEP_SEMI_BYTES)


def problem_for(case: Case, scheme: Scheme, nx: int, grading: float = 1.0,
                keep: bool = True) -> Any:
    """The problem a run integrates (`_discretise`) at nx with the scheme's mass variant,
    from `PROBLEMS` when this process built it already (`keep` False: built afresh and
    not kept, e.g. a reference's finer one); a mesh the case refuses (e.g. a mass that is
    not positive definite) is a BenchError. The problem is shared: never changed."""
    nx, grading = int(nx), float(grading)
    if not keep:
        return _discretise(case, scheme, nx, grading)
    key = (case_key(case), nx, grading, scheme.mass_kind())
    return PROBLEMS.get_or_build(key, lambda: _discretise(case, scheme, nx, grading))


def declared_limit(case: Case, scheme: Scheme, problem: Any) -> float | None:
    """The scheme's declared stability limit (largest stable dt) on the scene's
    space-discrete problem (`Scheme.stability_limit`: the mesh's own eigenvalues where
    the scheme computes them, else a 1D formula at the problem's hmin and c_max)."""
    return scheme.stability_limit(problem)


def compile_seconds(events: list) -> float:
    """The time numba spent compiling (or loading from its cache), from the events of a
    `numba.core.event.install_recorder("numba:compile")`: the outermost start-end pairs."""
    total, depth, start = 0.0, 0, 0.0
    for stamp, event in events:
        if event.is_start:
            if depth == 0:
                start = stamp
            depth += 1
        elif event.is_end and depth > 0:
            depth -= 1
            if depth == 0:
                total += stamp - start
    return total


def prepare_stepper(scheme: Scheme, problem: Any, dt: float,
                    phases: dict[str, float] | None = None) -> tuple[Stepper, float]:
    """`scheme.prepare(problem, dt)` and its time (`setup_s`), JIT compilation during it
    subtracted; `phases` (given): filled with the time of its factorisations and contact
    operators (`contact_bench.core.timers`; seconds, compilation not subtracted)."""
    with numba_event.install_recorder("numba:compile") as compiled, recording() as spent:
        start = time.perf_counter()
        stepper = scheme.prepare(problem, dt)
        elapsed = time.perf_counter() - start
    if phases is not None:
        phases.update(spent)
    return stepper, max(0.0, elapsed - compile_seconds(compiled.buffer))


def on_axis(axis: AxisView, traj: Trajectory) -> Trajectory:
    """The trajectory's samples on an axis view's dofs (for a 1D reference's norms)."""
    return dataclasses.replace(traj, U=np.ascontiguousarray(traj.U[:, axis.dofs]),
                               V=np.ascontiguousarray(traj.V[:, axis.dofs]))


def contact_metrics(problem: Any, traj: Trajectory) -> dict[str, Any]:
    """The many-node contact columns of a sparse run: status switches (chatter), first
    contact start and end, peak total contact force, the friction work at the last
    sample (`contact_bench.core.contact_stats.friction_update`; None without friction),
    and the symmetry defect (largest spread of U over the groups of dofs the scene
    declares equal, over the samples)."""
    extra = traj.extra
    out = {k: extra.get(k) for k in ("chatter", "first_contact_start", "first_contact_end",
                                       "peak_contact_force")}
    work = extra.get("friction_work")
    out["friction_work"] = float(work[-1]) if work is not None and len(work) else None
    groups = getattr(problem, "equal_groups", ())
    if groups and traj.U.shape[1]:  # by blocks of samples: no copy of all the samples
        rows = max(1, SYMMETRY_BLOCK // max(1, traj.U.shape[1]))
        out["symmetry_defect"] = max(
            float(np.max(np.ptp(traj.U[a:a + rows][:, g], axis=-1)))
            for g in groups for a in range(0, traj.U.shape[0], rows))
    return out


#: values of U gathered at once for the symmetry defect (`contact_metrics`)
SYMMETRY_BLOCK = 2**22


def _check_length(case: Case) -> float:
    """The bar's length, checked (material and data are checked in `discretise`)."""
    try:
        L = float(case.L)
    except (TypeError, ValueError):
        raise BenchError(f"case {case.spec}: L = {case.L!r} must be a number > 0") from None
    if not (math.isfinite(L) and L > 0):
        raise BenchError(f"case {case.spec}: L = {case.L!r} must be finite and > 0")
    return L


def _check_size(case: Case) -> float:
    """The scene's characteristic length (`Case.size`), checked."""
    size = case.size
    try:
        value = float(size)
    except (TypeError, ValueError):
        raise BenchError(f"case {case.spec}: size = {size!r} must be a number > 0") from None
    if not (math.isfinite(value) and value > 0):
        raise BenchError(f"case {case.spec}: size = {size!r} must be finite and > 0")
    return value


def _execute(plan: _Plan, step_repeats: int = STEP_REPEATS) -> Run:
    """Integrate a prepared configuration and fill in its metrics (`step_s`: the minimum
    of `step_repeats` timed stepping calls, `step_time`)."""
    row, notes = plan.row, plan.notes
    if plan.semi is None:  # not applicable
        return Run(row)
    case, scheme, semi, dt = plan.case, plan.scheme, plan.semi, plan.dt
    norm_s = None
    if semi is _REBUILD:  # dropped after the checks to bound a table's memory
        semi = problem_for(case, scheme, row["nx"], row["grading"])
    sparse = banded(semi) is None
    ref_samples = numerical_reference(case, plan, notes) if case.quantities else None
    phases: dict[str, float] = {}
    stepper, row["setup_s"] = prepare_stepper(scheme, semi, dt, phases)
    row["setup_factor_s"] = phases.get("factor", 0.0)
    row["setup_contact_s"] = phases.get("contact", 0.0)
    row["assembly_s"] = semi.assembly_s
    key = ("stepper", type(scheme), scheme.mass_kind(), scheme.traits().implicit, case.form)
    if key not in _warmed:  # one kernel each; JIT compilation stays out of run_s, step_s
        stepper.run(1, 1)
        _warmed.add(key)
    long_run = _predicted_s(stepper, plan.steps) > STEP_BUDGET_S
    if not long_run:
        # the stepping alone first: its arrays are freed before the recorded run
        # allocates its samples, so a run's memory peak stays the recorded run's
        row["step_s"] = step_time(stepper.run, plan.steps, step_repeats)
    start = time.perf_counter()
    traj = stepper.run(plan.steps, plan.stride)
    row["run_s"] = row["wall_s"] = time.perf_counter() - start
    if long_run and traj.steps_done == plan.steps:
        # one long call: a second call for the stepping alone would double the run's
        # time (`step_time` too takes one call over the budget as the measurement)
        row["step_s"] = row["run_s"]
        notes.append(f"step_s is the recorded run's (one call over {STEP_BUDGET_S:g} s, "
                     f"a sample every {plan.stride} steps"
                     + (", their recording included)" if plan.stride < LONG_RUN_STRIDE
                        else ")"))
    elif long_run or traj.steps_done < plan.steps:
        # the stepping alone (a stopped run: the steps it made)
        row["step_s"] = step_time(stepper.run, traj.steps_done, step_repeats)
    del stepper  # its factors go before the norms and the reference run
    if sparse:
        row.update(contact_metrics(semi, traj))
        row.update(impact_metrics(semi, traj, dt))
        table = impact_table(semi, traj)
        if table is not None:  # impact by impact, for the run's outputs (impacts.csv)
            traj.extra["impact_table"] = table
    if ref_samples is not None:
        row["ref_s"], row["ref_compute_s"] = ref_samples.pop("ref_s"), ref_samples["s"].seconds
        row["ref_from_cache"] = ref_samples.pop("ref_from_cache")
        row.update(case.quantity_errors(semi, traj, row, reference=ref_samples.pop("s")))
    elif case.quantities:
        row.update(case.quantity_errors(semi, traj, row))

    row.update(energy_metrics(traj))
    row["penetration_max"] = penetration(traj)
    if traj.blowup_time is not None:
        row.update(status="unstable", blowup_time=traj.blowup_time)
        notes.append(f"blew up at t = {traj.blowup_time:.6g} (stopped after "
                     f"{traj.steps_done} of {plan.steps} steps)")
    else:
        row["status"] = "ok"
        exact = reference(case, plan.T_run) if case.reference else None
        grid, samples = banded(semi) or semi, traj  # what the error norms read
        if sparse and exact is not None:  # a 1D reference, read on the problem's axis
            if semi.axis is None:
                exact = None
            else:
                grid, samples = semi.axis, on_axis(semi.axis, traj)
        if exact is None:
            # a scene's closed form may have filled some: `Case.quantity_errors`
            filled = {NEEDS[c] for c in ERROR_COLUMNS if row.get(c) is not None}
            if not filled:
                notes.append("errors: no reference solution")
            elif missing := sorted({NEEDS[c] for c in ERROR_COLUMNS} - filled):
                notes.append(f"reference has no {', '.join(missing)}")
        else:
            if ("norms",) not in _warmed:
                metrics.warm_up()  # norm kernels compiled (or loaded) outside norm_s
                _warmed.add(("norms",))
            if ("reference", type(exact)) not in _warmed:  # and the reference's own
                metrics.warm_up_reference(exact, grid.x, traj.t, case.provides)
                _warmed.add(("reference", type(exact)))
            start = time.perf_counter()
            row.update(error_metrics(grid, samples, exact, case.provides, plan.shared,
                                     notes))
            norm_s = time.perf_counter() - start
            # the first contact's quantities (an exact reference of the contact stress)
            row.update(first_contact_errors(case, exact, plan.T_run, traj, dt, semi))
            missing = sorted({NEEDS[c] for c in ERROR_COLUMNS} - set(case.provides))
            if missing:
                notes.append(f"reference has no {', '.join(missing)}")
            if case.reference == "numerical":
                notes.append("errors against a numerical reference")
    if plan.time_error > 1 and row["status"] == "ok":
        row.update(time_errors(case, scheme, semi, traj, row, plan.steps, plan.stride,
                               plan.time_error, notes))
    row["notes"] = "; ".join(notes)
    return Run(row, traj, semi, norm_s)


def numerical_reference(case: Case, plan: _Plan, notes: list[str]) -> dict[str, Any] | None:
    """The samples of the scene's declared reference run for this plan
    (`Case.reference_run`; None: it declares none), from the reference cache or computed
    now (`contact_bench.harness.reference_cache`), before the run so that its memory is
    gone when the run's samples are made: {"s": the samples, "ref_s": the time this run
    spent getting them, JIT compilation excluded, "ref_from_cache": read back, not
    computed}. The row's note names the reference run."""
    request = case.reference_run(plan.row["nx"], plan.dt, plan.T_run, plan.stride)
    if request is None:
        return None
    with numba_event.install_recorder("numba:compile") as compiled:
        start = time.perf_counter()
        samples = reference_samples(case, request)
        spent = time.perf_counter() - start
    spent = max(0.0, spent - compile_seconds(compiled.buffer))
    # the note is the same at every execution: computed or read back is `ref_from_cache`
    notes.append(f"numerical reference: {samples.description} (its cost: ref_compute_s)")
    return {"s": samples, "ref_s": spent, "ref_from_cache": samples.cached}


#: steps of the probe that predicts a run's time (`_predicted_s`)
PROBE_STEPS = 20


def _predicted_s(stepper: Stepper, steps: int) -> float:
    """A run's stepping time predicted from a probe of at most `PROBE_STEPS` steps."""
    probe = min(steps, PROBE_STEPS)
    start = time.perf_counter()
    stepper.run(probe, probe)
    return (time.perf_counter() - start) * steps / probe


def step_time(run: Callable[[int, int], Trajectory], steps: int,
              repeats: int = STEP_REPEATS, budget_s: float = STEP_BUDGET_S) -> float | None:
    """The stepping alone: `run(steps, steps)` (a prepared `Stepper.run`; samples at the
    first and the last step only), the minimum over up to `repeats` timed calls after a
    discarded warm-up call, stopping once the timed calls took `budget_s` (at least one
    call). A warm-up call longer than `budget_s` is the measurement, unless numba
    compiled during it (a kernel form the runner's one-step warm-up did not reach, e.g.
    one chosen by the number of steps): then it is timed again. None for 0 steps.
    """
    if steps < 1:
        return None
    with numba_event.install_recorder("numba:compile") as compiled:
        start = time.perf_counter()
        run(steps, steps)
        first = time.perf_counter() - start
    if first > budget_s and not compiled.buffer:
        return first
    best, spent, calls = math.inf, 0.0, 0
    while calls < max(1, repeats) and not (calls >= 1 and spent > budget_s):
        start = time.perf_counter()
        run(steps, steps)
        elapsed = time.perf_counter() - start
        best, spent, calls = min(best, elapsed), spent + elapsed, calls + 1
    return best


def _error_row(case: Case, scheme: Scheme, nx: Any, dt: Any, T: Any, stride: Any,
               grading: Any, exc: BaseException, row: dict[str, Any] | None = None) -> Run:
    """The row of a run that raised an unexpected exception (a bug, not a bad input)."""
    try:
        declared = quantity_columns(case)
    except Exception:  # noqa: BLE001 - a broken declaration leaves the base columns
        declared = ()
    out: dict[str, Any] = dict.fromkeys((*BASE_COLUMNS, *declared, *(row or ())))
    out.update(case=case.spec, scheme=scheme.spec, nx=nx, dt=dt, T=T, stride=stride,
               grading=grading, reference=case.reference or "none")
    if row is not None:
        out.update({k: v for k, v in row.items() if v is not None})
    reason = " ".join(f"{type(exc).__name__}: {exc}".split())
    if out.get("notes"):
        reason = f"{reason}; {out['notes']}"
    out.update(status="error", notes=reason, **dict.fromkeys(TIMING_COLUMNS))
    tb = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
    return Run(out, traceback=tb)


def run_one(case: Case | str, scheme: Scheme | str, nx: int | None = None,
            dt: float | None = None, T: float | None = None, stride: int | None = None,
            grading: float = 1.0, allow_unstable: bool = False, *, strict: bool = False,
            step_repeats: int = STEP_REPEATS, time_error: int = 0,
            problem: Any = None) -> Run:
    """Run one configuration. Bad input raises BenchError; a blow-up is a row.

    stride None: the case's default `Case.stride` (lowered to the number of steps).
    A pair that cannot run is a 'not applicable' row, or a BenchError when `strict`
    (the user asked for exactly this combination). The error norms keep what the next
    run on the same grid can reuse (`contact_bench.harness.metrics`): a sweep's worker runs its
    tasks
    one after the other. `run_table` knows its runs and keeps only for a later one.
    `step_repeats`: the timed calls of `step_s` (`step_time`). `time_error` > 1: the
    columns err_time_u, err_time_stress against the same scheme at dt / time_error
    (`contact_bench.harness.time_error`, a cached reference). `problem`: the scene's
    problem at (nx, grading) with the scheme's mass (`problem_for`), when the caller has
    it (a sweep task hands on the one it read the step limit from); None: built here.
    """
    case = make_case(case) if isinstance(case, str) else case
    scheme = make_scheme(scheme) if isinstance(scheme, str) else scheme
    plan = _prepare(case, scheme, nx, dt, T, stride, grading, allow_unstable, strict,
                    problem)
    plan.time_error = int(time_error)
    return _execute(plan, step_repeats)


def run_table(cases: Iterable[str], schemes: Iterable[str], nxs: Iterable[int | None] = (None,),
              dts: Iterable[float | None] = (None,), T: float | None = None,
              stride: int | None = None,
              grading: float = 1.0, allow_unstable: bool = False,
              keep: list[Run] | None = None, *, explicit_pair: bool = False,
              keep_samples: bool = True,
              progress: Callable[[int, int, Case, Scheme], None] | None = None,
              time_error: int = 0,
              after_run: Callable[[Run], None] | None = None) -> pd.DataFrame:
    """The product cases x schemes x nx x dt as one DataFrame (one row per run).

    Every configuration is checked before any is run, so a bad input (BenchError) fails
    at once and nothing is half done. A run that blows up is an 'unstable' row, a run
    that raises anything else an 'error' row with the reason; the table goes on.
    `explicit_pair`: the user named one case and one scheme, so a pair that cannot run
    is an error rather than a 'not applicable' row. `keep` collects the runs; with
    `keep_samples` False they are kept `Run.without_samples()`, so that memory does not
    grow with the number of runs (one run's samples at a time). `progress(i, total,
    case, scheme)` is called before each run (the CLI's progress line). `time_error`: as
    `run_one`'s. `after_run(run)` is called after each run that stepped, with its
    samples (before `keep_samples` drops them): the CLI's fields and pictures.
    """
    case_objs = [make_case(c) if isinstance(c, str) else c for c in cases]
    scheme_objs = [make_scheme(s) if isinstance(s, str) else s for s in schemes]
    nxs, dts = list(nxs), list(dts)
    strict = explicit_pair and len(case_objs) == 1 and len(scheme_objs) == 1
    plans: list[_Plan | Run | None] = []
    for case in case_objs:
        for scheme in scheme_objs:
            for nx in nxs:
                for dt in dts:
                    try:
                        plans.append(_prepare(case, scheme, nx, dt, T, stride, grading,
                                              allow_unstable, strict))
                    except BenchError:
                        raise
                    except Exception as exc:  # noqa: BLE001 - a broken plugin is a row
                        plans.append(_error_row(case, scheme, nx, dt, T, stride, grading, exc))
    later: set[tuple] = set()  # the last run on a grid keeps nothing for the next ones
    for plan in reversed(plans):
        if isinstance(plan, _Plan) and (grid := plan.grid()) is not None:
            plan.shared = grid in later
            later.add(grid)
    kept = 0  # large semi-discrete problems are not all held from the checks on
    for plan in plans:
        if isinstance(plan, _Plan) and plan.semi is not None:
            size = _semi_bytes(plan.semi)
            if kept and kept + size > KEEP_SEMI_BYTES:
                plan.semi = _REBUILD
            else:
                kept += size
        if isinstance(plan, _Plan):
            plan.time_error = int(time_error)
    rows = []
    for i, plan in enumerate(plans):
        plans[i] = None  # each run's memory goes with it
        if progress is not None and isinstance(plan, _Plan):
            progress(i, len(plans), plan.case, plan.scheme)
        if isinstance(plan, Run):
            run = plan
        else:
            assert plan is not None
            try:
                run = _execute(plan)
            except Exception as exc:  # noqa: BLE001 - one failing run never stops a table
                before = dict(plan.row, notes="; ".join(plan.notes) or None)
                run = _error_row(plan.case, plan.scheme, plan.row["nx"], plan.row["dt"],
                                 plan.row["T"], plan.row["stride"], plan.row["grading"], exc,
                                 before)
        if after_run is not None and run.trajectory is not None:
            after_run(run)
        rows.append(run.row)
        if keep is not None:
            keep.append(run if keep_samples else run.without_samples())
        del plan, run
    import pandas as pd  # here: not loaded while the runs step (its memory adds to theirs)

    return pd.DataFrame(rows, columns=table_columns(rows))


def _semi_bytes(semi: Any) -> int:
    if hasattr(semi, "nbytes"):  # a sparse problem tells its size
        return int(semi.nbytes)
    return sum(a.nbytes for a in (semi.x, semi.M.diag, semi.M.off, semi.K.diag, semi.K.off,
                                   semi.F, semi.U0, semi.V0))


def quantity_columns(case: Case) -> tuple[str, ...]:
    """The relative error columns `err_<q>` of the quantities q the case declares
    (`Case.reference_quantities`), sorted by name: its rows have them, empty when a run
    does not fill them."""
    return tuple(sorted(f"err_{q}" for q in case.reference_quantities))


def table_columns(rows: Iterable[Mapping[str, Any]],
                  base: Sequence[str] = BASE_COLUMNS) -> list[str]:
    """A table's columns: `base`, then every other column of its rows sorted by name
    (the scenes' `err_<q>`, `quantity_columns`, and any other a plugin's row carries),
    so that no column is dropped and the order does not depend on the rows' order."""
    return [*base, *sorted({k for row in rows for k in row} - set(base))]
