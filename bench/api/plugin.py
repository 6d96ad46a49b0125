"""The two plugin kinds, schemes and cases (scenes), and what passes between them.

A *case* (scene) is a 1D bar (`BarCase`) or a 2D/3D body (`BodyCase`), with its data and
(if known) its exact solution; it declares what exists for it (`Case.quantities`). A
*scheme* declares how it integrates in time (`Scheme.traits`) and turns a `Semidiscrete`
problem into a `Trajectory`. The harness only reads these declarations: it never branches
on a plugin's name.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from enum import StrEnum
from typing import Any, ClassVar, NamedTuple, Protocol

import numpy as np

from contact_bench.api.params import Param, check_params, format_spec
from contact_bench.core.errors import BenchError


class Plugin:
    """Base of schemes and cases: declared parameters, checked at construction."""

    name: ClassVar[str] = ""
    summary: ClassVar[str] = ""
    params: ClassVar[dict[str, Param]] = {}

    def __init__(self, **given: Any) -> None:
        self.values = check_params(self.name, self.params, given)
        for key, value in self.values.items():
            setattr(self, key, value)
        self.validate()

    def validate(self) -> None:
        """Cross-parameter checks; raise BenchError. Default: nothing to check."""

    @property
    def spec(self) -> str:
        return format_spec(self.name, self.params, self.values)

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.spec}>"


# ----------------------------------------------------------------------------- cases


def flat_points(x: Any, t: Any) -> tuple[np.ndarray, np.ndarray, tuple[int, ...]]:
    """x and t broadcast against each other, as contiguous 1-D arrays (for a compiled
    evaluation of an exact solution at the points (x, t)), and the broadcast shape.

    Contiguous copies on purpose: a compiled loop over broadcast (strided) views runs
    several times slower than the copy costs.
    """
    x, t = np.asarray(x, float), np.asarray(t, float)
    shape = np.broadcast_shapes(x.shape, t.shape)

    def flat(a: np.ndarray) -> np.ndarray:
        # an expanded operand is copied from a read-only broadcast view (a writeable
        # one is deprecated: numpy warns when numba reads its flags)
        return (np.ascontiguousarray(a) if a.shape == shape
                else np.broadcast_to(a, shape).copy()).ravel()

    return flat(x), flat(t), shape


class Fields(NamedTuple):
    """An exact solution's outputs as its compiled kernels take them: u, u_x and u_t (an
    empty array when the velocity is not wanted), one entry per point or (`fields_into`)
    one row per time."""

    u: np.ndarray
    ux: np.ndarray
    ut: np.ndarray


def grid_points(x: Any, t: Any, *out: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """x and t as contiguous 1-D float arrays, after checking that every output given
    (None skipped) is a writeable C-contiguous float64 array of shape (t.size, x.size):
    the arguments of an exact solution's `fields_into` (whose compiled kernels write
    there without bounds checks)."""
    x = np.ascontiguousarray(x, dtype=float)
    t = np.ascontiguousarray(t, dtype=float)
    if x.ndim != 1 or t.ndim != 1:
        raise ValueError(f"fields_into: x and t must be 1-D, got {x.shape} and {t.shape}")
    for arr in out:
        if arr is not None and not (
                isinstance(arr, np.ndarray) and arr.dtype == np.float64
                and arr.shape == (t.size, x.size) and arr.flags.c_contiguous
                and arr.flags.writeable):
            raise ValueError("fields_into: outputs must be writeable C-contiguous float64 "
                             f"arrays of shape {(t.size, x.size)}")
    return x, t


#: relative slack of `checked_interval`: a value this far (relative) out is clipped back
INTERVAL_SLACK = 1e-12


def check_positive(name: str, value: float) -> float:
    """value as a float, or a one-line ValueError naming it unless it is > 0 and finite
    (an exact solution's L, E, rho, T)."""
    value = float(value)
    if not (value > 0.0 and np.isfinite(value)):
        raise ValueError(f"{name} must be positive and finite, got {value!r}")
    return value


def checked_far_end(far_end: str, u_L: float) -> tuple[str, float]:
    """(far_end, u_L as a float), or a one-line ValueError naming the bad one: far_end
    "clamped" or "free", u_L finite (an exact solution's far end)."""
    if far_end not in ("clamped", "free"):
        raise ValueError(f"far_end must be 'clamped' or 'free', got {far_end!r}")
    u_L = float(u_L)
    if not np.isfinite(u_L):
        raise ValueError(f"u_L must be finite, got {u_L!r}")
    return far_end, u_L


def checked_interval(name: str, a: Any, hi: float, where: str) -> np.ndarray:
    """a as a float array clipped to [0, hi], or a one-line ValueError naming its first
    value outside [0, hi] by more than INTERVAL_SLACK * hi (NaN included): "{name} =
    {value} outside {where}" (an exact solution's x in the bar, t in [0, T])."""
    a = np.asarray(a, dtype=float)
    slack = INTERVAL_SLACK * hi
    if a.size and not (np.min(a) >= -slack and np.max(a) <= hi + slack):
        bad = float(a[~((a >= -slack) & (a <= hi + slack))].ravel()[0])
        raise ValueError(f"{name} = {bad!r} outside {where}")
    return np.clip(a, 0.0, hi)


class Exact(Protocol):
    """An exact (or reference) solution; arrays broadcast against each other.

    Optional, for the error norms (`contact_bench.harness.metrics`): `fields(x, t, velocity)` giving
    (u, u_x, u_t or None) at once, and `fields_into(x, t, u, ux, ut=None)` writing the
    same values at the points (x[m], t[k]) into given (t.size, x.size) arrays
    (`grid_points`), so that the norms keep them without temporaries.
    """

    def u(self, x: np.ndarray, t: np.ndarray) -> np.ndarray: ...
    def ut(self, x: np.ndarray, t: np.ndarray) -> np.ndarray: ...
    def ux(self, x: np.ndarray, t: np.ndarray) -> np.ndarray: ...
    def stress(self, t: np.ndarray) -> np.ndarray: ...


#: the quantities of a reference's first contact (`Case.reference_quantities`): its start
#: and end times, its duration, its peak contact force and its impulse (the force's
#: integral over it; force and impulse per unit section)
CONTACT_QUANTITIES = ("contact_start", "contact_end", "contact_duration", "peak_force",
                      "contact_impulse")
#: the impulse a run transfers over the reference's first contact interval, against that
#: contact's impulse (a run whose first contact breaks into bounces is measured on the
#: momentum it transfers: `contact_bench.harness.quantities`)
INTERVAL_IMPULSE = "impulse_over_reference_contact"


@dataclass(frozen=True)
class StudyGrid:
    """How the study (`contact_bench.sweeps.study`) and the registry-driven tests run a
    sparse scene: small grids that still hold an impact.

    `specs`: the scene's variants in the study (e.g. a faster impact); `nx`: their
    refinements, coarse to fine (work-precision; the first for stability); `T`: the
    study's final time (None: the scene's). `small`, `small_nx`, `small_T`: one variant,
    its grids smallest first (a scheme whose mass variant the scene refuses on one takes
    the next) and a short final time after the first impact: the quick study and the
    tests. `in_default_study`: the study without named scenes (`contact-bench study`,
    results/study) runs the scene; False for a scene on a user's file (mesh_body), which
    the tests still run on its bundled default and a study runs when named.
    `friction`: the scene's frictional variants (each with a Coulomb coefficient as its
    parameter `mu` > 0) in the study's friction part (`contact_bench.sweeps.study.
    plan_friction`): work-precision on `nx` at T, stability in CFL against mu on the
    coarsest mesh; empty (the default): the scene is not in it. `friction_stability_T`:
    the final time of those stability runs when the part's default (a multiple of T) is
    longer (a scene whose T already holds a whole impact and the flight after it);
    None: the part's default.
    """

    specs: tuple[str, ...]
    nx: tuple[int, ...]
    T: float | None
    small: str
    small_nx: tuple[int, ...]
    small_T: float
    in_default_study: bool = True
    friction: tuple[str, ...] = ()
    friction_stability_T: float | None = None


class Case(Plugin):
    """A scene: what every scene declares, whatever it is (a 1D bar, `BarCase`, or a
    2D/3D body, `BodyCase`): its default resolution and final time, its reference and
    the quantities it provides, the problem form it produces, and the labels of its
    contact observable and contact force.

    A scene derives from one of the two kinds, never from `Case` directly: the harness
    reads only what each kind declares. A class deriving from `Case` directly, and a
    named body scene without a `size`, are a one-line TypeError at their definition (a
    plugin file defining one is listed as broken). Subclasses set the class attributes
    (or properties, when they depend on params).
    """

    T: float = 1.0
    nx: int = 40
    dt: float = 0.01
    #: default sampling stride (keep a sample every `stride` steps) when the user gives
    #: none; long runs set it so that the samples stay few
    stride: int = 1
    #: "exact" (closed form or characteristics), "numerical" (a fine run) or None
    reference: ClassVar[str | None] = None
    #: fields the reference provides: subset of {"u", "v", "stress", "energy"} (its
    #: scalar quantities: `reference_quantities`)
    provides: ClassVar[frozenset[str]] = frozenset()
    #: part of the default `contact-bench run` (the two scenes of Dabaghi, Petrov,
    #: Pousin, Renard 2014)
    in_default_run: ClassVar[bool] = False
    #: a stiff scene (physical units, short time scale): the study's stability part runs it
    stiff: ClassVar[bool] = False
    #: the scene kind ("bar" or "body"), set by `BarCase` and `BodyCase`
    kind: ClassVar[str] = ""
    #: what `Trajectory.contact_u` holds on this kind of scene (figure axes, `list`)
    contact_label: ClassVar[str] = ""
    #: what `Trajectory.stress` holds on this kind of scene (figure axes, `list`)
    force_label: ClassVar[str] = ""

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        if not cls.kind:
            raise TypeError(f"{cls.__name__} derives from Case; a scene derives from "
                            "BarCase (a 1D bar) or BodyCase (a 2D/3D body)")
        if cls.name and cls.size is Case.__dict__["size"]:
            raise TypeError(f"{cls.__name__} ({cls.name}) declares no size: a body scene "
                            "sets its characteristic length `size` (e.g. its diameter)")

    @property
    def size(self) -> float:
        """The scene's characteristic length: the harness bounds a run's final time in
        wave transits T c_max / size. A bar's is its length; a body declares its own."""
        raise BenchError(f"case {self.spec} declares no size (its characteristic length, "
                         "e.g. a body's diameter)")

    def declarations(self) -> dict[str, Any]:
        """What the scene is, for `contact-bench list`: name -> value (a number, a
        string, or a function of x)."""
        return {}

    def exact(self, T: float) -> Exact | None:
        """The reference solution on [0, T], or None."""
        return None

    @property
    def exact_energy(self) -> float | None:
        """The conserved energy of the continuous problem, if known."""
        return None

    def cannot_run(self, scheme: Scheme) -> str | None:
        """A reason why this scene cannot be run by the scheme, or None."""
        return None

    def data_hash(self) -> str:
        """A digest of the data files the scene reads at run time (a mesh file), folded
        into the sweep cache's keys so that a changed file runs again; "" (the default):
        none beyond its code and parameters."""
        return ""

    #: the problem form this scene produces (`contact_bench.api.sparse.FORMS`): the 1D
    #: bar's banded `Semidiscrete`, or a `SparseProblem` from `sparse_problem`
    form: ClassVar[str] = "banded1d"

    def sparse_problem(self, nx: int, grading: float, mass_kind: str) -> Any:
        """The `contact_bench.api.sparse.SparseProblem` of a sparse-form scene at
        resolution nx with the scheme's mass variant (`Scheme.mass_kind`)."""
        raise NotImplementedError

    #: the reference quantities this scene provides beyond the fields of `provides`, each
    #: giving the row a relative error column `err_<quantity>` (`quantity_errors`)
    quantities: ClassVar[frozenset[str]] = frozenset()

    @property
    def reference_quantities(self) -> frozenset[str]:
        """Every quantity q whose relative error err_q the row gets: the scene's own
        (`quantities`, computed by `quantity_errors`) and, when its reference is exact
        and provides the contact stress, the first contact's (`CONTACT_QUANTITIES`
        and `INTERVAL_IMPULSE`,
        computed once for all such scenes by the harness from `exact(T).stress`:
        `contact_bench.harness.quantities`). A reference without a positive contact
        force in [0, T] (a grazing touch) or whose contact lasts to T gives fewer."""
        if self.reference == "exact" and "stress" in self.provides:
            return self.quantities | frozenset((*CONTACT_QUANTITIES, INTERVAL_IMPULSE))
        return self.quantities

    #: the study's and the tests' grids of a sparse scene (`StudyGrid`); every sparse
    #: scene declares one
    study: ClassVar[StudyGrid | None] = None

    #: a production code's verification case: its published values by quantity q (each a
    #: `contact_bench.exact.published.Published`: value, relative tolerance, source),
    #: whose errors the scene's `quantity_errors` gives as err_published_<q>. The study
    #: runs every scheme on such a scene once, at the scene's own grid, and tabulates
    #: those errors against the tolerances. Empty: not a verification case.
    published: ClassVar[dict[str, Any]] = {}

    def quantity_errors(self, problem: Any, traj: Trajectory, row: dict[str, Any]
                        ) -> dict[str, float]:
        """The relative errors `err_<q>` of a run in the quantities q of `quantities`
        (the run's trajectory and the row's contact columns against the reference). A
        scene that declares a `reference_run` takes it as `reference=` (its samples,
        `contact_bench.api.reference_run.ReferenceSamples`)."""
        return {}

    def reference_run(self, nx: int, dt: float, T: float, stride: int) -> Any:
        """The fine run (`contact_bench.api.reference_run.ReferenceRun`) that a run at
        (nx, dt, T, stride) is compared with, or None: the harness computes it once,
        keeps it on disk and reports its cost apart (`ref_s`)."""
        return None


class BarCase(Case):
    """A 1D bar scene: the bar (0, L) with density `rho` and Young modulus `E` (numbers,
    or functions of x), gravity `g`, its far end x = L `clamped` at `u_L` or `free`, the
    initial data `u0`, `v0` (u0(0) >= 0), and its exact solution if any. The obstacle
    is at x = 0; its problem is the banded `Semidiscrete` (`contact_bench.api.problem.
    discretise`).

    Subclasses set the class attributes (or properties) and implement `u0`, `v0` and,
    when there is one, `exact`.
    """

    kind = "bar"
    contact_label = "u(0, t)"
    force_label = "contact stress E u_x(0, t)"

    L: float = 1.0
    rho: float = 1.0
    E: float = 1.0
    g: float = 0.0
    far_end: str = "clamped"  # "clamped" (u(L) = u_L) or "free" (u_x(L) = 0)
    u_L: float = 0.0

    def u0(self, x: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def v0(self, x: np.ndarray) -> np.ndarray:
        return np.zeros_like(np.asarray(x, dtype=float))

    @property
    def wave_speed(self) -> float:
        return float(np.sqrt(self.E / self.rho))

    @property
    def size(self) -> float:
        """The bar's length L."""
        return self.L

    def declarations(self) -> dict[str, Any]:
        return {"L": self.L, "rho": self.rho, "E": self.E, "g": self.g,
                "far_end": self.far_end}


class Footprint(NamedTuple):
    """A body's size before it is built: its unknowns (vector dofs), dimension and
    polynomial degree."""

    unknowns: int
    dim: int
    degree: int


class BodyCase(Case):
    """A 2D/3D body scene: an elastic body, its data and its obstacle, given as the
    sparse problem it produces at a resolution (`sparse_problem`: mass, stiffness, load,
    initial data, contact set, smallest element, largest wave speed `c_max`).

    It declares its characteristic length `size` (e.g. its diameter; there is no
    default: reading it undeclared is a one-line BenchError) and the study's grids
    (`study`). Its contact observable is the smallest gap of the contact set and its
    contact stress the total contact force over the contact zone's measure (the sparse
    kernels' `-sum(lambda) / area`, or the contact law's stress over that measure).
    """

    kind = "body"
    form = "sparse"
    contact_label = "smallest gap"
    force_label = "contact stress (total force / zone measure)"

    #: its problem carries a time-dependent load (`contact_bench.api.sparse.TimeLoad`)
    time_load: ClassVar[bool] = False
    #: the dimension of the body's space, its problem's `SparseProblem.dim` (2 for a
    #: plane or axisymmetric section, 3 for a solid; 1 for bars joined end to end): a
    #: class attribute, a property or the scene's `dim` param; a derived scene gives its
    #: base's. A scheme's `cannot_run` reads it (how many tangents a contact point has);
    #: 0, the default, is undeclared (tests/test_scene_kinds.py requires every body
    #: scene to declare it)
    dim: int = 0

    def declarations(self) -> dict[str, Any]:
        return {"size": self.size}

    def footprint(self, nx: int) -> Footprint | None:
        """The body's size at resolution nx, counted without building it (for the
        memory check made before assembly: `contact_bench.harness.footprint`); None
        (the default): not declared, nothing is checked."""
        return None

    def body(self, nx: int) -> Any:
        """The assembled body at resolution nx (`contact_bench.api.fem_nd.Elasticity`)
        whose every vector dof is an unknown of `sparse_problem` in the same order, for
        the fields and pictures of a run (`contact_bench.output.fields`); None (the
        default): the scene gives none."""
        return None

    def friction(self) -> float:
        """The largest friction coefficient (or Tresca threshold) of the scene's contact;
        0 (the default): frictionless."""
        return 0.0

    def cannot_run(self, scheme: Scheme) -> str | None:
        if self.time_load and not scheme.adds_time_load():
            return ("the scene has a time-dependent load, which this scheme's stepper "
                    "does not add (Scheme.adds_time_load)")
        if self.friction() > 0 and not scheme.traits().friction:
            return (f"the scene has friction (mu = {self.friction():g} > 0) and this scheme "
                    "declares no friction law (Traits.friction)")
        return None


# --------------------------------------------------------------------------- schemes


@dataclass(frozen=True)
class Semidiscrete:
    """The space-discrete problem on the free dofs 0..nfree-1 (node 0 = contact node).

    A clamped far end is eliminated: its value sits in `u_fixed` and its coupling in F.
    The energy of a state is 1/2 V.M.V + 1/2 U.K.U - F.U + energy_offset, which equals
    kinetic + strain + gravity potential of the full nodal vector.
    """

    x: np.ndarray
    nfree: int
    M: Any  # contact_bench.api.fem.Tridiag over the free dofs
    K: Any
    F: np.ndarray
    U0: np.ndarray
    V0: np.ndarray
    u_fixed: float | None
    energy_offset: float
    massless: bool
    E_contact: float  # Young modulus in the first element (contact stress = E u_x(0))
    c_max: float  # largest wave speed

    @property
    def h(self) -> np.ndarray:
        return np.diff(self.x)

    @property
    def hmin(self) -> float:
        return float(self.h.min())

    def full(self, U: np.ndarray, fill_velocity: bool = False) -> np.ndarray:
        """Nodal values on all nodes (appends the clamped node along the last axis)."""
        if self.u_fixed is None:
            return U
        pad = np.full(U.shape[:-1] + (1,), 0.0 if fill_velocity else self.u_fixed)
        return np.concatenate([U, pad], axis=-1)


@dataclass
class Trajectory:
    """What a scheme returns: samples every `stride` steps (and the last step).

    `contact_u` is the scene's contact observable (`Case.contact_label`): on a bar
    (`BarCase`) u(0, t), the contact node's displacement `U[:, 0]`; on a body
    (`BodyCase`) the smallest gap of the contact set, min_i (gap0_i + U[:, dof_i]).
    `min_contact_u` is its minimum over every step. `stress` is the contact stress
    (`Case.force_label`): on a bar E u_x(0, t), on a body the total contact force over
    the contact zone's measure; negative in compression on both.
    """

    t: np.ndarray  # (K,)
    U: np.ndarray  # (K, nfree) displacement samples
    V: np.ndarray  # (K, nfree) velocity samples
    contact_u: np.ndarray  # (K,) bar: u(0, t); body: the smallest gap
    stress: np.ndarray  # (K,) numerical contact stress (<= 0 for compression)
    energy: np.ndarray  # (K,) the scheme's discrete energy (incl. penalty/Nitsche terms)
    min_contact_u: float  # min over *all* steps of contact_u (not only the samples)
    steps_done: int
    blowup_time: float | None = None  # first time NaN/inf or energy > 1e3 E(0)
    extra: dict[str, Any] = field(default_factory=dict)


class Energy(StrEnum):
    """How a scheme's discrete energy (`Trajectory.energy`) behaves over a run.

    A str enum: it prints, and compares equal to, its value ("conserved", ...).
    """

    CONSERVED = "conserved"  # |E(t) - E(0)| within Scheme.energy_drift_bound
    DISSIPATED = "dissipated"  # E(t) never grows beyond that bound (or round-off)
    MAY_GROW = "may grow"  # nothing claimed (e.g. energy jumps at impacts)


class Contact(StrEnum):
    """How a scheme enforces the Signorini condition u(0, t) >= 0, and its error.

    A str enum: it prints, and compares equal to, its value ("exact", ...).
    """

    EXACT = "exact"  # u(0, t_n) >= 0 at every step (Lagrange multiplier, projection)
    PENALTY = "penalty O(1/kappa)"  # penetration of order 1/kappa
    NITSCHE = "Nitsche O(h / gamma0)"  # penetration of order h / gamma0
    VELOCITY_LEVEL = "velocity-level O(dt v)"  # contact on velocities: penetration O(dt v)
    RESTITUTION = "restitution O(e dt v)"  # a restitution law: penetration O(e dt v)


class Family(StrEnum):
    """The class a scheme belongs to in Doyen, Ern, Piperno (SIAM J. Sci. Comput. 33, 2011),
    the classification the field's comparisons use.

    A str enum: it prints, and compares equal to, its value ("exact", ...).
    """

    EXACT = "exact"  # the constraint on displacements at a time level (multiplier, projection)
    PENALTY = "penalty"  # a contact force from the penetration (penalty, Nitsche)
    VELOCITY = "velocity"  # the constraint or an impact law on velocities
    MODIFIED_MASS = "modified mass"  # no inertia at the contact dofs (mass redistribution)


def default_family(contact: Contact, massless_contact_node: bool) -> Family:
    """The class read from the other traits when a scheme does not declare it: a massless
    contact node is a modified mass; else penalty and Nitsche are penalised, velocity-level
    and restitution laws velocity schemes, and exact contact exact."""
    if massless_contact_node:
        return Family.MODIFIED_MASS
    if contact in (Contact.PENALTY, Contact.NITSCHE):
        return Family.PENALTY
    if contact in (Contact.VELOCITY_LEVEL, Contact.RESTITUTION):
        return Family.VELOCITY
    return Family.EXACT


@dataclass(frozen=True)
class Traits:
    """What a scheme declares about itself.

    `contact` and `energy` are enums; their values given as strings are converted (a
    one-line BenchError names a value that is not one of them).
    """

    implicit: bool
    massless_contact_node: bool
    contact: Contact
    energy: Energy
    order: int | None = None  # expected time order away from impacts
    family: Family | None = None  # Doyen-Ern-Piperno's class; None: `default_family`
    #: the scheme applies a friction law (`ContactSet.friction` / `tresca`); a scheme
    #: without one is refused a scene with friction (`BodyCase.cannot_run`)
    friction: bool = False
    #: the integrator picks its own steps and dt only sets the sampling (an adaptive
    #: reference): the study plans no dt-convergence or stability runs for it
    adaptive: bool = False

    def __post_init__(self) -> None:
        for name, kind in (("contact", Contact), ("energy", Energy), ("family", Family)):
            value = getattr(self, name)
            if value is None and name == "family":
                value = default_family(self.contact, self.massless_contact_node)
            try:
                object.__setattr__(self, name, kind(value))
            except ValueError:
                allowed = ", ".join(repr(k.value) for k in kind)
                raise BenchError(f"Traits.{name} = {value!r}: not one of {allowed}") from None


def on_curved_obstacle(problem: Any) -> bool:
    """Whether `problem`'s contact is a curved obstacle (`contact_bench.api.sparse.
    ContactSet.obstacle`): its gaps are nonlinear, so a claim resting on a fixed gap
    operator (an energy conserved exactly) does not hold there (`Scheme.traits(problem)`)."""
    return getattr(getattr(problem, "contact", None), "obstacle", None) is not None


class Stepper:
    """A scheme prepared for one problem and one step size: what does not depend on the
    number of steps (factorisations, Delassus or Schur operators, contact laws, the
    initial acceleration) is made once, by `Scheme.prepare`; `run(nsteps, stride)`
    steps from the problem's initial state, afresh at each call (a warm-up, timing
    repeats and the recorded run share one stepper)."""

    def run(self, nsteps: int, stride: int) -> Trajectory:
        raise NotImplementedError


class CallStepper(Stepper):
    """A stepper with nothing to prepare: `run` calls `step(nsteps, stride)`."""

    def __init__(self, step: Callable[[int, int], Trajectory]) -> None:
        self.step = step

    def run(self, nsteps: int, stride: int) -> Trajectory:
        return self.step(nsteps, stride)


class Scheme(Plugin):
    """A time-integration / contact scheme: it declares what it is (`traits`) and
    prepares a `Stepper` for a problem and a step size (`prepare`).

    The problem has one form in every dimension (`contact_bench.api.sparse.
    SparseProblem`'s attributes: sparse M and K, the gap operator, loads, initial data);
    a bar's problem also carries its tridiagonal form (`contact_bench.api.problem.banded`),
    the fast backend the built-in 1D kernels take.
    """

    def prepare(self, problem: Any, dt: float) -> Stepper:
        """The stepper of this scheme on `problem` with step `dt` (module docstring)."""
        raise NotImplementedError

    def integrate(self, problem: Any, dt: float, nsteps: int, stride: int) -> Trajectory:
        """One run: `prepare(problem, dt).run(nsteps, stride)` (a bar's `Semidiscrete`
        is taken as its problem, `contact_bench.api.problem.as_problem`)."""
        from contact_bench.api.problem import as_problem  # the problem layer imports this one

        return self.prepare(as_problem(problem, self.mass_kind()), dt).run(int(nsteps),
                                                                          int(stride))

    def traits(self, problem: Any = None) -> Traits:
        """What the scheme declares; on `problem`, what holds there (a property that
        holds on the bar's single contact node may not on many: e.g. Nitsche with a
        massless contact node is exact contact on the bar). None: the general problem."""
        raise NotImplementedError

    def mass_kind(self) -> str:
        """Which `contact_bench.api.fem` mass variant the scheme uses."""
        return "consistent"

    def stability_limit(self, problem: Any) -> float | None:
        """Largest stable dt on the problem (None: none). A 1D formula reads
        `problem.hmin` and `problem.c_max`; an explicit scheme whose formula does not
        bound a 2D/3D mesh's eigenvalues computes them (`contact_bench.kernels.
        sparse_explicit.stable_dt`)."""
        return None

    def cannot_run(self, case: Case) -> str | None:
        """A reason why the scheme cannot run this scene, or None."""
        return None

    def adds_time_load(self) -> bool:
        """Whether its stepper on a body adds a time-dependent load (`contact_bench.api.
        sparse.SparseProblem.load`): a scene with one (`BodyCase.time_load`) is not
        applicable to the others. Default: False."""
        return False

    def follows_curved_obstacle(self) -> bool:
        """Whether its stepper on a body follows a curved obstacle (`contact_bench.api.
        sparse.ContactSet.obstacle`: the gaps re-linearised every step): a scene with one
        is not applicable to the others. Default: False."""
        return False

    def penetration_bound(self, problem: Any, dt: float) -> float:
        """Largest penetration max_t -u(0, t) the scheme admits on the bar (exact
        contact: 0).

        Round-off comes on top: callers compare with bound + 1e-12 * max|U0|.
        """
        return 0.0

    def energy_drift_bound(self, problem: Any, dt: float) -> float | None:
        """Bound on max |E(t) - E(0)| / |E(0)| the scheme claims (None: no claim).

        Meaningful for traits().energy == Energy.CONSERVED (and Energy.DISSIPATED: no
        growth beyond this bound).
        """
        return None

    def newmark_parameters(self) -> tuple[float, float] | None:
        """(beta, gamma) when the scheme is the plain Newmark method on its mass matrix
        with the contact enforced exactly at t_{n+1} (the independent scipy
        re-implementation `contact_bench.harness.scipy_reference` then checks it), else
        None."""
        return None
