"""The scene library: every scene runs through the CLI and converges; the
special properties each scene claims hold for its exact (or numerical) reference."""

from __future__ import annotations

import io

import numpy as np
import pandas as pd
import pytest

from contact_bench.api.fem import mesh_nodes
from contact_bench.api.problem import discretise
from contact_bench.api.registry import cases, make_case, make_scheme
from contact_bench.cli.main import main
from contact_bench.core.errors import BenchError
from contact_bench.exact.characteristics import CharacteristicsSolution
from contact_bench.harness.runner import problem_for, run_one

# tuned short windows of the built-in scenes: spec, final time (several impacts where the
# scene has them) and the transit time L / c that scales dt. Every scene of the registry
# is tested: one not listed here (a scene added later) runs with its default parameters
# over min(T, WINDOW_TRANSITS size / c_max) (`Case.size`: a bar's L, a body's own).
SHORT = {
    "clamped_bar": ("clamped_bar", 1.5, 1.0),  # the impact at t = 1
    "dropped_bar": ("dropped_bar", 1.5, 1.0 / 3.0),
    "rough_data": ("rough_data", 2.0, 1.0),  # first contact [0.5, 1.7]
    "pulse": ("pulse", 3.0, 1.0),  # two contacts
    "grazing": ("grazing", 1.5, 1.0),  # the touch at t = 1
    "long_time": ("long_time", 30.0, 1.0),  # 10 periods
    "fast_impact": ("fast_impact[mach=0.1]", 2.5, 1.0),  # contact [0.1, 2.1]
    "steel_bar": ("steel_bar", 1e-3, 1.0 / 5188.745216627708),  # contact [5e-4, 8.85e-4] s
    "heterogeneous_bar": ("heterogeneous_bar", 1.5, 0.5),  # c_max = 2
}
WINDOW_TRANSITS = 4.0
NXS = (20, 40, 80)


def _window(name: str) -> tuple[str, float, float]:
    """(spec, T, transit) of a registered scene (see SHORT)."""
    if name in SHORT:
        return SHORT[name]
    case = make_case(name)
    transit = case.size / problem_for(case, make_scheme("standard[mass=consistent]"),
                                      NXS[0]).c_max
    return name, min(float(case.T), WINDOW_TRANSITS * transit), transit


def _cli_table(args: list[str], capsys) -> pd.DataFrame:
    code = main(["run", *args, "--format", "csv"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    return pd.read_csv(io.StringIO(captured.out))


@pytest.mark.parametrize("name", cases().names())
def test_scene_runs_through_the_cli_and_converges(name, capsys):
    if make_case(name).reference is None:  # a body with reference quantities only
        pytest.skip(f"{name}: no reference solution of u to converge to")
    spec, T, transit = _window(name)
    dt = 0.25 * transit / NXS[-1]  # CFL 1/4 on the finest mesh
    args = ["--case", spec, "--scheme", "redistributed", "--T", f"{T!r}", "--dt", f"{dt!r}"]
    for nx in NXS:
        args += ["--nx", str(nx)]
    df = _cli_table(args, capsys)
    assert list(df["nx"]) == list(NXS)
    assert (df["status"] == "ok").all(), df["notes"].tolist()
    case = make_case(spec)
    columns = ["err_u_linf_l2", "err_u_l2_h1"]
    if "v" in case.provides:
        columns.append("err_v_l2_l2")
    if "stress" in case.provides:
        columns.append("err_stress_l2")
    else:
        assert df["err_stress_l2"].isna().all()
    for col in columns:
        e = df[col].to_numpy()
        assert np.all(np.isfinite(e)) and np.all(np.diff(e) < 0), (col, e)
    assert df["err_u_linf_l2"].iloc[0] / df["err_u_linf_l2"].iloc[-1] > 1.8  # order >~ 1/2
    if case.reference == "numerical":
        assert (df["reference"] == "numerical").all()
        assert df["notes"].str.contains("numerical reference").all()


def test_every_scene_runs_on_a_graded_mesh():
    for name in cases().names():
        case = make_case(name)
        if case.form == "sparse" and case.exact(1.0) is None:  # a body, not a bar in 2D/3D
            with pytest.raises(BenchError, match="grading = 2.0"):  # refused by value
                run_one(case, "redistributed", nx=2, grading=2.0)
            continue
        _, T, transit = _window(name)
        dt = 0.25 * transit / 16
        run = run_one(case, "redistributed", nx=16, dt=dt, T=T, grading=2.0)
        assert run.row["status"] == "ok", (name, run.row["notes"])
        assert run.row["grading"] == 2.0
        x = run.problem.axis.x  # a bar's problem reads along its axis too
        assert x[1] - x[0] == pytest.approx(case.size / 16**2)  # x_i = L (i / nx)^2
        errs = [run.row[c] for c in ("err_u_linf_l2", "err_v_l2_l2")]
        assert all(np.isfinite(errs)), (name, errs)


def test_graded_mesh_errors_decrease_for_a_new_scene(capsys):
    errs = [run_one("rough_data", "redistributed", nx=nx, dt=0.25 / 64, T=2.0,
                    grading=1.5).row["err_u_linf_l2"] for nx in (16, 32, 64)]
    assert errs[2] < errs[1] < errs[0]
    # through the CLI, against the numerical reference (computed on its own uniform mesh)
    df = _cli_table(["--case", "heterogeneous_bar", "--scheme", "redistributed", "--T", "1",
                     "--dt", "0.002", "--nx", "16", "--nx", "32", "--grading", "1.5"], capsys)
    assert (df["status"] == "ok").all() and (df["grading"] == 1.5).all()
    assert df["err_u_linf_l2"].iloc[1] < df["err_u_linf_l2"].iloc[0]


# -------------------------------------------------------------------- scene claims
def _grazing_characteristics(case, T):
    """The characteristics solution of the grazing scene's data (an independent
    computation: it finds the contact from the data, knowing nothing of the mode)."""
    return CharacteristicsSolution(L=case.L, E=case.E, rho=case.rho, far_end=case.far_end,
                                   u0=case.u0, v0=0.0, T=T)


def test_grazing_really_grazes():
    case = make_case("grazing")
    ex = _grazing_characteristics(case, case.T)
    intervals = ex.contact_intervals()
    assert [a for a, _ in intervals] == pytest.approx([1.0, 3.0], abs=1e-12)
    assert all(b - a == 0.0 for a, b in intervals)  # a touch, no contact period
    t = np.linspace(0.0, case.T, 4001)
    u0 = ex.u(0.0, t)
    assert u0.min() >= -1e-15
    np.testing.assert_allclose(u0, 0.1 * (1 + np.cos(np.pi * t)), atol=1e-9)  # free motion
    assert np.abs(ex.stress(t)).max() < 1e-3  # O(ds) from sampling the cosine
    # zero velocity at the touch (up to the O(ds) of the sampled data), from both sides
    for tt in (1.0, 3.0):
        assert abs(ex.ut(0.0, tt)) < 1e-4 and abs(ex.ut(0.0, tt - 1e-9)) < 1e-4
    # and a bar started a little lower would really hit (so the touch is a limit case)
    lower = CharacteristicsSolution(L=1.0, E=1.0, rho=1.0, far_end="free",
                                    u0=lambda x: 0.099 + 0.1 * np.cos(np.pi * x), v0=0.0,
                                    T=1.5)
    (a, b), = lower.contact_intervals()
    assert b - a > 0.02
    assert "stress" not in case.provides  # the relative stress error would be 0 / 0


def test_grazing_closed_form_is_the_characteristics_solution():
    """The scene's reference (the free motion, in closed form) against the
    characteristics solution of its data on the 20000-cell grid: u to its O(ds^2)
    interpolation error of the cosine, u_x and u_t to O(ds); and it starts from the
    scene's data, with free ends."""
    case = make_case("grazing")
    closed, chars = case.exact(case.T), _grazing_characteristics(case, case.T)
    rng = np.random.default_rng(3)
    x = np.sort(rng.uniform(0.0, case.L, 300))
    t = np.concatenate(([0.0, 1.0, 3.0, case.T], rng.uniform(0.0, case.T, 60)))
    u, ux, ut = (np.empty((t.size, x.size)) for _ in range(3))
    closed.fields_into(x, t, u, ux, ut)
    X, T = np.broadcast_arrays(x[None, :], t[:, None])
    np.testing.assert_allclose(u, chars.u(X, T), rtol=0, atol=1e-9)
    np.testing.assert_allclose(ux, chars.ux(X, T), rtol=0, atol=1e-4)
    np.testing.assert_allclose(ut, chars.ut(X, T), rtol=0, atol=1e-4)
    assert np.abs(ut).max() > 0.1 and np.abs(ux).max() > 0.1  # not trivially small
    # fields, u, ux, ut: the values of fields_into
    for got, want in zip(closed.fields(X, T), (u, ux, ut), strict=True):
        np.testing.assert_array_equal(got, want)
    np.testing.assert_array_equal(closed.u(X, T), u)
    np.testing.assert_array_equal(closed.ux(X, T), ux)
    np.testing.assert_array_equal(closed.ut(X, T), ut)
    np.testing.assert_allclose(closed.u(x, 0.0), case.u0(x), rtol=0, atol=1e-16)
    assert np.all(closed.ut(x, 0.0) == 0.0)
    tt = np.linspace(0.0, case.T, 801)
    assert np.abs(closed.ux(np.array([0.0, case.L]), tt[:, None])).max() < 1e-16
    assert closed.u(0.0, tt).min() >= 0.0 and closed.u(0.0, 1.0) < 1e-17
    assert np.all(closed.stress(tt) == 0.0)
    # without u_t: u and u_x unchanged
    u2, ux2 = np.empty_like(u), np.empty_like(u)
    closed.fields_into(x, t, u2, ux2)
    np.testing.assert_array_equal(u2, u)
    np.testing.assert_array_equal(ux2, ux)


def test_fast_impact_mach_range_is_enforced(capsys):
    for bad in ("0.6", "1e-4", "0", "-0.1", "nan"):
        with pytest.raises(BenchError, match=r"fast_impact\[mach="):
            make_case(f"fast_impact[mach={bad}]")
    assert main(["run", "--case", "fast_impact[mach=0.7]", "--scheme", "redistributed"]) == 2
    assert "allowed: float in [0.001, 0.5]" in capsys.readouterr().err
    for mach in (1e-3, 0.5):
        case = make_case(f"fast_impact[mach={mach}]")
        ex = case.exact(case.T)
        (a, b), = ex.contact_intervals()
        assert a == pytest.approx(0.01 / mach, rel=1e-12)
        assert b - a == pytest.approx(2.0, rel=1e-12)
        assert ex.stress(0.5 * (a + b)) == pytest.approx(-mach, rel=1e-12)
        assert ex.energy(case.T) == pytest.approx(case.exact_energy, rel=1e-12)


def test_steel_bar_contact_lasts_two_transits():
    case = make_case("steel_bar")
    c = np.sqrt(210e9 / 7800)
    assert c == pytest.approx(5189, abs=0.5)
    ex = case.exact(case.T)
    (a, b), = ex.contact_intervals()
    assert a == pytest.approx(5e-5 / 0.1, rel=1e-12)
    assert b - a == pytest.approx(2.0 / c, rel=1e-12)
    assert ex.stress(0.5 * (a + b)) == pytest.approx(-7800 * c * 0.1, rel=1e-12)
    assert ex.ut(0.5, case.T) == pytest.approx(0.1, rel=1e-12)  # leaves at +v0
    assert ex.energy(case.T) == pytest.approx(0.5 * 7800 * 0.1**2, rel=1e-12)


def test_long_time_closed_form_energy_at_late_times():
    case = make_case("long_time")
    ex = case.exact(case.T)
    xq = (np.arange(4000) + 0.5) / 4000  # midpoints: exact for piecewise constant fields
    for t in np.linspace(2990.0, 3000.0, 7) + 0.013:
        e = 0.5 * np.mean(ex.ut(xq, t) ** 2 + ex.ux(xq, t) ** 2)
        assert e == pytest.approx(0.125, abs=2e-3)  # cells cut by the fronts: O(1/4000)
    # the closed form agrees with the characteristics solver at late times (the solver is
    # exact for these data on a grid of 20 cells per length)
    ch = CharacteristicsSolution(L=1.0, E=1.0, rho=1.0, u0=([0.0, 1.0], [0.5, 0.0]), v0=0.0,
                                 T=3000.0, cells_per_length=20)
    rng = np.random.default_rng(3)
    x, t = rng.uniform(0, 1, 300), rng.uniform(2950.0, 3000.0, 300)
    np.testing.assert_allclose(ch.u(x, t), ex.u(x, t), atol=1e-10)
    assert ch.energy(2999.37) == pytest.approx(0.125, rel=1e-9)
    assert case.exact_energy == 0.125


def test_long_time_default_stride():
    case = make_case("long_time")
    assert case.stride > 1 and not case.in_default_run
    run = run_one("long_time", "redistributed", T=30.0)
    assert run.row["stride"] == case.stride
    assert run.trajectory.t.size == 6000 // case.stride + 1
    short = run_one("long_time", "redistributed", T=0.1)  # 20 steps < default stride
    assert short.row["stride"] == 20 and short.row["status"] == "ok"
    with pytest.raises(BenchError, match="stride"):  # an explicit stride is still checked
        run_one("long_time", "redistributed", T=0.1, stride=50)
    assert run_one("clamped_bar", "redistributed", T=0.1).row["stride"] == 1


def test_heterogeneous_bar_reference_and_callable_E():
    case = make_case("heterogeneous_bar")
    ref = case.exact(1.0)
    assert case.exact(2.0) is ref  # cached: a sweep does not recompute it
    assert ref.t[-1] >= case.T
    # the reference interpolates its own trajectory
    i = ref.t.size // 2
    np.testing.assert_allclose(ref.u(ref.x, ref.t[i]), ref.U[i])
    assert ref.ut(0.7, 0.0) == pytest.approx(-0.5)
    # its contact: hits at t = 0.1, stress about -rho c v = -0.5 at the first instants
    assert ref.stress(0.05) == 0.0
    assert ref.stress(0.3) == pytest.approx(-0.5, rel=0.05)
    # callable E: largest wave speed and contact modulus, also with a jump inside an element
    for grading in (1.0, 1.7):
        semi = discretise(case, mesh_nodes(1.0, 15, grading), "seed")
        assert semi.c_max == pytest.approx(2.0)
        assert semi.E_contact == 1.0
    soft = make_case("heterogeneous_bar[contrast=0.25]")
    assert discretise(soft, mesh_nodes(1.0, 15), "seed").c_max == pytest.approx(1.0)


def test_list_shows_what_each_scene_provides(capsys):
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    lines = out.splitlines()
    for name in cases().names():
        i = next(k for k, line in enumerate(lines) if line.split()[:1] == [name])
        detail = lines[i + 1]
        assert "provides=" in detail and "reference=" in detail, detail
    grazing = lines[next(k for k, ln in enumerate(lines) if ln.split()[:1] == ["grazing"]) + 1]
    assert "provides=energy,u,v (not: stress)" in grazing
    assert "stride=50" in out and "no gravity" in out and "g=10" in out
    assert "reference=numerical" in out


def test_pulse_reference_against_dalembert_before_and_at_the_first_impact():
    """pulse (c = 1): away from the pulse, u = gap (1 - max(x, t)) (the stress-free end
    relaxes the uniform strain); the first contact starts where the free motion of the
    end, w(t) = gap (1 - t) - 2 A b((t - x0) / w), reaches 0, and ends where it stops
    falling, w'(t) = 0 (d'Alembert by hand, roots by scipy: not the reference's code,
    which works on the reflected and shifted copies of its table)."""
    from scipy.optimize import brentq

    from contact_bench.cases.pulse import AMPLITUDE, CENTER, GAP, WIDTH, _bump

    ref = make_case("pulse").exact(1.0)
    x, t = np.meshgrid(np.linspace(0.0, 0.29, 30), np.linspace(0.0, 0.29, 30))
    ahead = x + t < CENTER - WIDTH  # the pulse (moving left) has not reached (x, t)
    u, ux, ut = ref.fields(x[ahead], t[ahead])
    xa, ta = x[ahead], t[ahead]
    assert np.allclose(u, GAP * (1.0 - np.maximum(xa, ta)), rtol=0.0, atol=1e-12)
    off = np.abs(xa - ta) > 1e-9  # the kink x = t: limits from the future there
    assert np.allclose(ux[off], np.where(xa > ta, -GAP, 0.0)[off], rtol=0.0, atol=1e-12)
    assert np.allclose(ut[off], np.where(ta > xa, -GAP, 0.0)[off], rtol=0.0, atol=1e-12)
    assert np.allclose(ref.stress(np.linspace(0.0, 0.29, 30)), 0.0, rtol=0.0, atol=1e-12)

    def w(s: float) -> float:
        return GAP * (1.0 - s) - 2.0 * AMPLITUDE * float(_bump((s - CENTER) / WIDTH)[0])

    def dw(s: float) -> float:
        return -GAP - 2.0 * AMPLITUDE / WIDTH * float(_bump((s - CENTER) / WIDTH)[1])

    start = brentq(w, CENTER - WIDTH, CENTER, xtol=1e-14)
    end = brentq(dw, CENTER, CENTER + WIDTH / 2, xtol=1e-14)
    (a, b), *_ = ref.contact_intervals()
    # both by root finding on the closed forms (to round-off)
    assert abs(a - start) < 1e-13 and abs(b - end) < 1e-13, (a, start, b, end)
    assert 0.339 < start < 0.341 and 0.504 < end < 0.506  # the docstring's [0.340, 0.505]
