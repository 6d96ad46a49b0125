"""A body too large for the machine is refused before anything is built (issue 48, item 5).

The declared footprints are checked against the problems the scenes build (an independent
count: the assembled unknowns), and the refusal is checked to come before the mesh.
"""

from __future__ import annotations

import subprocess
import sys

import pytest

from contact_bench.api.registry import make_case, make_scheme
from contact_bench.core.errors import BenchError
from contact_bench.harness import footprint, runner

SPECS = [("disc_drop[degree=1]", (1, 2, 5)), ("disc_drop[degree=2]", (1, 3)),
         ("sphere_drop", (1, 2, 4)), ("sphere_drop[degree=2]", (1, 2)),
         ("sphere_drop[ball=lattice]", (1, 3, 5)), ("sphere_drop[ball=lattice,degree=2]", (3,)),
         ("manufactured[dim=2]", (1, 3)), ("manufactured[dim=2,degree=2]", (1, 3)),
         ("manufactured[dim=3]", (1, 3)), ("manufactured[dim=3,degree=2]", (1, 2)),
         ("two_discs", (2,)), ("two_discs[half=1]", (2,)), ("two_discs[rings_b=1]", (2,)),
         ("two_balls", (2,)), ("two_balls[half=1]", (2,)), ("two_balls[ball_b=lattice]", (2,)),
         ("two_balls[ball=lattice,degree=2]", (3,)),
         ("slanted_drop", (2,)),
         ("slanted_drop[of=sphere_drop]", (2,)), ("curved_drop[of=disc_drop[degree=1]]", (2,)),
         ("curved_drop[of=sphere_drop]", (2,))]


@pytest.mark.parametrize("spec,nxs", SPECS)
def test_footprint_counts_the_built_unknowns(spec: str, nxs: tuple[int, ...]) -> None:
    case = make_case(spec)
    for nx in nxs:
        fp = case.footprint(nx)
        problem = case.sparse_problem(nx, 1.0, "consistent")
        assert fp.unknowns == problem.U0.size, (spec, nx)
        assert fp.dim == problem.dim


def _forbid_building(monkeypatch: pytest.MonkeyPatch, spec: str) -> None:
    def built(*_a, **_k):
        raise AssertionError(f"{spec}: built before the size was refused")

    for of in (spec, "disc_drop", "sphere_drop"):
        for name in ("mesh", "body", "sparse_problem"):
            monkeypatch.setattr(type(make_case(of)), name, built, raising=False)


@pytest.mark.parametrize("spec,nx,scheme", [("disc_drop", 2000, "redistributed"),
                                            ("sphere_drop", 64, "redistributed"),
                                            ("slanted_drop", 4000, "standard")])
def test_oversize_refused_before_assembly(monkeypatch: pytest.MonkeyPatch, spec: str,
                                          nx: int, scheme: str) -> None:
    monkeypatch.setattr(footprint, "memory_limit", lambda: (24e9, "the memory available"))
    _forbid_building(monkeypatch, spec)
    case, sch = make_case(spec), make_scheme(scheme)
    with pytest.raises(BenchError) as err:
        runner.check_run(case, sch, nx, None, None, None)
    text = str(err.value)
    assert "\n" not in text and f"nx = {nx}" in text and "24 GB" in text


def test_allowed_nx_is_the_largest_that_fits(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(footprint, "memory_limit", lambda: (2e9, "a test limit"))
    case, sch = make_case("disc_drop"), make_scheme("standard")
    with pytest.raises(BenchError, match=r"allowed: nx <= (\d+)") as err:
        footprint.check_fits(case, sch, 1000)
    top = int(str(err.value).rsplit("nx <= ", 1)[1])
    factored = footprint.factors(sch)
    assert footprint.estimate_bytes(case.footprint(top), factored) <= 2e9
    assert footprint.estimate_bytes(case.footprint(top + 1), factored) > 2e9
    footprint.check_fits(case, sch, top)  # fits: no error


def test_a_diagonal_mass_needs_no_factor() -> None:
    case = make_case("sphere_drop")
    fp = case.footprint(32)
    lumped, implicit = (make_scheme("taylor_flanagan[mass=lumped]"),
                        make_scheme("redistributed"))
    assert not footprint.factors(lumped) and footprint.factors(implicit)
    assert (footprint.estimate_bytes(fp, False) < footprint.estimate_bytes(fp, True))


def test_million_dof_ball_estimate_near_its_measured_peak() -> None:
    """The lumped explicit lattice ball at nx 62 (976,875 unknowns, no factor): the
    estimate within a factor of two of the growth `benchmarks/scale.py --scene ball_1e6`
    measured (4,160 MiB, docs/scale.md), so that a machine with 8 GB available runs it."""
    case, sch = make_case("sphere_drop[ball=lattice]"), make_scheme("taylor_flanagan[mass=lumped]")
    fp = case.footprint(62)
    assert fp.unknowns == 976_875
    estimate = footprint.estimate_bytes(fp, footprint.factors(sch))
    assert 0.5 < estimate / (4160.1 * 2**20) < 2.0
    assert estimate < 8e9


def test_memory_limit_is_the_smallest(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(footprint, "_meminfo_available", lambda: 8e9)
    monkeypatch.setattr(footprint, "_cgroup_limit", lambda: 5e9)
    assert footprint.memory_limit() == (5e9, "the cgroup's memory limit")
    monkeypatch.setattr(footprint, "_cgroup_limit", lambda: None)
    assert footprint.memory_limit()[0] == 8e9


def test_cli_refuses_in_one_line() -> None:
    """As a user types it, under an address-space limit of 6 GB (ulimit -v)."""
    code = ("import resource, sys; resource.setrlimit(resource.RLIMIT_AS, (6 << 30, "
            "resource.RLIM_INFINITY)); from contact_bench.cli.main import main; "
            "sys.exit(main(sys.argv[1:]))")
    proc = subprocess.run([sys.executable, "-c", code, "run", "--case", "sphere_drop",
                           "--nx", "64", "--scheme", "redistributed", "--quiet"],
                          capture_output=True, text=True, timeout=300)
    lines = proc.stderr.strip().splitlines()
    assert proc.returncode == 2, proc.stderr
    assert len(lines) == 1 and "nx = 64" in lines[0] and "ulimit -v" in lines[0]


def test_pardiso_2d_model_near_a_measured_factor() -> None:
    """The 2D PARDISO model's factor term against PARDISO's own report of a P2 disc's
    factor (iparm[15] + iparm[16]), a size outside the fit (nx 16; fitted at 24-144)."""
    from contact_bench.core import pardiso
    from contact_bench.kernels.linalg import Factor

    if pardiso.MKL is None:
        pytest.skip("MKL PARDISO not loaded")
    case = make_case("disc_drop[degree=2,lift=1e-6]")
    p = case.sparse_problem(16, 1.0, "redistributed")
    dt = float(case.dt)
    fac = Factor.of(p.M + 0.25 * dt * dt * p.K, pardiso=True)
    assert fac.kind == "pardiso"
    n = p.nfree
    m = footprint.PARDISO_MODELS[(2, 2)]
    assert 0.67 < m.factor * n * (n / 1e5) ** m.power / fac.nbytes < 1.5
    big = pardiso.PARDISO_MIN_DOFS
    assert footprint.model(2, 2, big) is m
    assert footprint.model(2, 2, big - 1) is footprint.MODELS[(2, 2)]
