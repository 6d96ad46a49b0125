"""The measurement scripts of benchmarks/ that README and results/ name still run.

Small inputs only (the real runs are the scripts' own commands): `norm_cost.py` in its
table and `--alone` modes, `memory.py` on a small mesh in a fresh process, and the
refusal of bad arguments by these and `eval_cost.py`, `startup.py` (one argparse line
naming the value, exit 2: unknown plugins by the registry's own message).
"""

from __future__ import annotations

import importlib.util
import json
from pathlib import Path

import numpy as np
import pytest

from contact_bench.api.registry import cases, schemes
from contact_bench.exact.characteristics import CharacteristicsSolution
from contact_bench.harness import metrics

ROOT = Path(__file__).resolve().parents[1]
# the registry's lists (a plugin added anywhere is in them)
ALL_SCHEMES = ", ".join(sorted(schemes().names()))
ALL_CASES = ", ".join(sorted(cases().names()))


def _script(name: str):
    spec = importlib.util.spec_from_file_location(f"_bench_{name}", ROOT / "benchmarks" /
                                                  f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _rows(out: str, header: list[str], footer: bool = True) -> list[list[str]]:
    """The split rows under the header (and above the footer line, if the script prints
    one)."""
    lines = out.strip().splitlines()
    assert lines[0].split()[: len(header)] == header, lines[0]
    return [line.split() for line in lines[1 : len(lines) - footer]]


@pytest.mark.parametrize("alone", [False, True])
def test_norm_cost_prints_one_row_per_scheme_with_its_ratio(capsys, alone):
    argv = ["clamped_bar", "--nx", "40", "--dt", "0.01", "--repeats", "1"]
    assert _script("norm_cost").main(argv + (["--alone"] if alone else [])) == 0
    out = capsys.readouterr().out
    rows = _rows(out, ["case", "scheme", "nx"])
    assert sorted(r[1] for r in rows) == sorted(schemes().names())
    for r in rows:
        wall, norm, ratio = float(r[5]), float(r[6]), float(r[7])  # ms, ms (0.01)
        assert r[0] == "clamped_bar" and r[2] == "40" and wall > 0.01 and norm > 0.01
        # the printed times are rounded to 0.005 ms, the ratio to 0.005
        assert (norm - 0.005) / (wall + 0.005) - 0.005 <= ratio
        assert ratio <= (norm + 0.005) / (wall - 0.005) + 0.005
    assert ("each scheme alone" if alone else "all schemes in one table") in out
    metrics.clear_cache()


def test_memory_reports_the_peak_of_a_fresh_run_process(capsys):
    # The parent holds 1 GiB of touched pages: a peak read through os.wait4's ru_maxrss
    # would inherit them across fork and exec; the run process's own peak does not.
    ballast = np.ones(2**27)
    assert _script("memory").main(["--nx", "2000", "--repeat", "1"]) == 0
    (row,) = _rows(capsys.readouterr().out, ["scheme", "nx", "stride"])
    assert row[:4] == ["standard", "2000", "100", "11"]
    peak = float(row[6])
    assert 50 < peak < 1000  # MB: a whole Python process with numba, not kB nor bytes
    assert ballast[-1] == 1.0


def test_eval_cost_rebuilds_a_characteristics_reference_on_the_grid_asked(capsys,
                                                                          monkeypatch):
    script = _script("eval_cost")
    built = []
    init = CharacteristicsSolution.__init__

    def spy(self, **kw):
        built.append(kw)
        init(self, **kw)

    monkeypatch.setattr(CharacteristicsSolution, "__init__", spy)
    assert script.main(["rough_data", "--cells-per-length", "200", "--repeats", "1"]) == 0
    (row,) = _rows(capsys.readouterr().out, ["case", "points"], footer=False)
    assert row[0] == "rough_data" and int(row[1]) == 1201 * 80 * 4 and float(row[2]) > 0.0
    kw = built[-1]  # after the case's own reference (unless the harness kept it)
    assert kw["cells_per_length"] == 200 and kw["T"] == 6.0 and kw["far_end"] == "clamped"


@pytest.mark.parametrize(("name", "argv", "message"), [
    ("norm_cost", ["--repeats", "0"], "--repeats must be >= 1, got 0"),
    ("memory", ["--repeat", "0"], "--repeat must be >= 1, got 0"),
    ("memory", ["--nx", "-5"], "--nx must be >= 1, got -5"),
    ("memory", ["--scheme", "bogus"], f"unknown scheme 'bogus'; allowed: {ALL_SCHEMES}"),
    ("startup", ["bogus"], f"unknown scheme 'bogus'; allowed: {ALL_SCHEMES}"),
    ("norm_cost", ["bogus"], f"unknown case 'bogus'; allowed: {ALL_CASES}"),
    ("norm_cost", ["clamped_bar", "--nx", "0"], "nx must be an integer in [2, 2e7], got 0"),
    ("eval_cost", ["bogus"], f"unknown case 'bogus'; allowed: {ALL_CASES}"),
    ("eval_cost", ["--cells-per-length", "0"], "--cells-per-length must be >= 1, got 0"),
    ("eval_cost", ["clamped_bar", "--cells-per-length", "100"], "--cells-per-length: the "
     "reference of clamped_bar is not a characteristics solution (ClampedBarExact)"),
    ("pulse_reference", ["--cells", "0"], "--cells and --points must be >= 1, got 0 and "
     "200000"),
    ("block_width", ["--width", "0"], "--width must be >= 1, got 0"),
    ("block_width", ["--matrix", "sphere_drop"], "--matrix 'sphere_drop': expected SPEC:NX "
     "with NX >= 1 (e.g. sphere_drop:16)"),
    ("block_width", ["--matrix", "no_such_scene:4"],
     f"unknown case 'no_such_scene'; allowed: {ALL_CASES}"),
])
def test_scripts_refuse_bad_arguments_in_one_line(capsys, name, argv, message):
    with pytest.raises(SystemExit) as exc:
        _script(name).main(argv)
    assert exc.value.code == 2
    assert capsys.readouterr().err.strip().splitlines()[-1].endswith(message)


def test_pulse_reference_shows_the_characteristics_solution_converging_to_it(capsys):
    """The former reference's distance to the d'Alembert one falls with its cells: like
    ds^2 on u, like ds on the slopes (a factor 4 of cells: about 16 and 4)."""
    assert _script("pulse_reference").main(["--cells", "250", "--cells", "1000",
                                            "--points", "5000"]) == 0
    coarse, fine = _rows(capsys.readouterr().out, ["cells", "max"])
    assert coarse[0] == "250" and fine[0] == "1000"
    du, dux = [float(coarse[k]) / float(fine[k]) for k in (1, 2)]
    assert 8.0 < du < 32.0 and 2.0 < dux < 8.0, (coarse, fine)


def _speedup_file(path: Path, speedups: dict[tuple[str, int], float]) -> Path:
    """A pytest-benchmark JSON file holding speedup benchmarks and one without a speedup."""
    benches = [{"name": f"test_speedup_over_scipy[{s}-{n}]",
                "extra_info": {"scheme": s, "nfree": n, "speedup": v}}
               for (s, n), v in speedups.items()]
    benches.append({"name": "test_stepping[standard-n1e3]",
                    "extra_info": {"scheme": "standard", "nfree": 1000, "speedup": None}})
    path.write_text(json.dumps({"benchmarks": benches}))
    return path


def test_summary_speedups_gives_each_run_and_the_min_median_max(tmp_path, capsys):
    """`summary.py --speedups`: one column per file, an empty cell where a file lacks the
    benchmark, min / median / max over the files that have it, rows by n then scheme."""
    a = _speedup_file(tmp_path / "a.json", {("standard", 1000): 54.0,
                                            ("redistributed", 1000): 49.5,
                                            ("standard", 100000): 120.0})
    b = _speedup_file(tmp_path / "b.json", {("standard", 1000): 56.0,
                                            ("redistributed", 1000): 51.5})
    c = _speedup_file(tmp_path / "c.json", {("standard", 1000): 50.0,
                                            ("redistributed", 1000): 50.0})
    assert _script("summary").main(["--speedups", str(a), str(b), str(c)]) == 0
    lines = capsys.readouterr().out.strip().splitlines()
    rows = [[cell.strip() for cell in line.strip("|").split("|")] for line in lines[4:]]
    assert rows == [
        ["redistributed", "1000", "49.5", "51.5", "50.0", "49.5", "50.0", "51.5"],
        ["standard", "1000", "54.0", "56.0", "50.0", "50.0", "54.0", "56.0"],
        ["standard", "100000", "120.0", "", "", "120.0", "120.0", "120.0"],
    ]


def test_summary_speedups_refuses_files_without_speedups_in_one_line(tmp_path, capsys):
    empty = _speedup_file(tmp_path / "empty.json", {})
    assert _script("summary").main(["--speedups", str(empty)]) == 2
    assert capsys.readouterr().err.strip() == (
        f"summary.py: error: no speedup benchmark (test_speedup_over_scipy) in {empty}")
    assert _script("summary").main(["--speedups"]) == 2
    assert "needs at least one JSON file" in capsys.readouterr().err
    bad = tmp_path / "bad.json"
    bad.write_text('{"machine_info": {}}')
    assert _script("summary").main(["--speedups", str(empty), str(bad)]) == 2
    assert capsys.readouterr().err.strip() == (
        f"summary.py: error: {bad} is not a pytest-benchmark JSON file of benchmarks/ "
        "(KeyError: 'benchmarks')")


def test_small_grids_prints_step_and_recording_per_scheme(capsys):
    specs = ["nitsche", "redistributed@serial", "redistributed@spike"]
    argv = ["--nx", "20", "--repeats", "1", "--dof-steps", "4000", "--specs", *specs]
    assert _script("small_grids").main(argv) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith("| 20 |")]
    cells = [[c.strip() for c in ln.strip("|").split("|")] for ln in lines]
    assert [c[1] for c in cells] == specs
    for c in cells:
        assert float(c[2]) > 0 and float(c[3]) > 0


def test_block_width_prints_a_time_per_column_for_each_width(capsys):
    _script("block_width").main(["--matrix", "disc_drop[degree=2]:3", "--width", "2",
                                 "--width", "5"])
    out = capsys.readouterr().out
    assert "`python benchmarks/block_width.py --matrix 'disc_drop[degree=2]:3' --width 2 " \
           "--width 5`" in out
    rows = [line for line in out.splitlines() if line.startswith("| disc_drop")]
    assert [r.split("|")[4].strip() for r in rows] == ["2", "5"]
    assert all(float(r.split("|")[5]) > 0 for r in rows)


def test_manufactured_orders_gives_each_scheme_a_stable_fixed_cfl(tmp_path, capsys):
    """An explicit scheme whose declared limit is below --cfl runs at 0.9 of it (the same
    CFL on each grid); an unconditionally stable one at --cfl; a tiny table has a row per
    grid with an order from the second on."""
    mod = _script("manufactured_orders")
    case = "manufactured[dim=2]"
    assert mod.scheme_cfl(case, "standard", 4, 0.5) == 0.5
    own = mod.scheme_cfl(case, "taylor_flanagan", 4, 0.5)
    limit = mod.declared_limit(mod.make_case(case), mod.make_scheme("taylor_flanagan"),
                               mod.problem_for(mod.make_case(case),
                                               mod.make_scheme("taylor_flanagan"), 4))
    assert own < 0.5 and own / (4 * mod.C_P) <= 0.9 * limit < (own + 0.01) / (4 * mod.C_P)
    out = tmp_path / "orders.md"
    assert mod.main(["--out", str(out), "--nx2", "2", "3", "--nx3", "2", "--schemes",
                     "taylor_flanagan"]) == 0
    df = mod.measure(2, [2, 3], 0.5, ["taylor_flanagan"])
    assert list(df["status"]) == ["ok", "ok"] and df["cfl"].nunique() == 1
    assert np.isnan(df["order_u_l2_l2"].iat[0]) and np.isfinite(df["order_u_l2_l2"].iat[1])
    assert "taylor_flanagan" in out.read_text()


def test_node_to_segment_takes_the_two_balls(capsys):
    """`--scene two_balls` runs the 3D pair against its half problem: at nx 2 only the
    pole touches within T = 0.8 (a node-to-node row whatever B's mesh), so a turned B
    gives the half problem's observables to round-off, and the momentum is kept."""
    _script("node_to_segment").main(["--scene", "two_balls", "--scheme", "penalty[beta=0]",
                                     "--nx", "2", "--T", "0.8"])
    out = capsys.readouterr().out
    assert out.startswith("penalty[beta=0], two_balls[degree=1,lift=0.505,turn_b=7]")
    row = [c.strip() for c in out.strip().splitlines()[-1].strip("|").split("|")]
    assert row[0] == "2" and row[1] == "past T"
    assert all(float(c) <= 1e-12 for c in row[2:]), row
