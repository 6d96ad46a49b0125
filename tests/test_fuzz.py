"""Fuzz: spec strings, every CLI option and `run_one`, with hypothesis.

Each generated input either runs or gives one stderr line (a `BenchError`), exit 2, no
traceback and nothing written. Inputs mix edge numbers (inf, nan, 1e308, 5e-324, -0, huge
integers), empty items and unicode with valid values; valid runs are kept cheap (nx <= 16,
T <= 0.1), so the CI profile takes seconds.

Profiles (environment variable CONTACT_BENCH_FUZZ): "ci" (default; a few dozen examples per
test) or "long" (thousands; a manual run of several minutes):

    CONTACT_BENCH_FUZZ=long .venv/bin/python -m pytest -q tests/test_fuzz.py -s
"""

from __future__ import annotations

import contextlib
import io
import os
from pathlib import Path

import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

from contact_bench.api.params import expand_spec  # noqa: E402
from contact_bench.api.registry import cases, make_case, make_scheme, schemes  # noqa: E402
from contact_bench.core.errors import BenchError  # noqa: E402

PROFILES = {"ci": {"spec": 150, "run_one": 25, "cli": 25},
            "long": {"spec": 5000, "run_one": 600, "cli": 600}}
PROFILE = os.environ.get("CONTACT_BENCH_FUZZ", "ci")
if PROFILE not in PROFILES:
    raise ValueError(f"CONTACT_BENCH_FUZZ must be one of {sorted(PROFILES)}, got {PROFILE!r}")
#: examples each test ran (printed at the end with -s: the counts for the notes)
COUNTS: dict[str, int] = {}


def _settings(name: str) -> settings:
    return settings(max_examples=PROFILES[PROFILE][name], deadline=None, database=None,
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                                           HealthCheck.filter_too_much])


def _count(name: str) -> None:
    COUNTS[name] = COUNTS.get(name, 0) + 1


@pytest.fixture(scope="module", autouse=True)
def _report_counts():
    yield
    print(f"\nfuzz profile {PROFILE!r}: examples run per test: {COUNTS}")


# ------------------------------------------------------------------ strategies
EDGE_NUMBERS = ["inf", "-inf", "nan", "NaN", "1e308", "-1e308", "1e999", "5e-324", "1e-320",
                "-0", "-0.0", "0", "1", "2", "0.5", "1e3", "2.5", "9" * 400, "-" + "9" * 30,
                "", " ", "abc", "1_000", "0x10", "٣", "１", "1e", "+", "--1", "1,2", "[1]",
                "\u00e9", "\x00", "1" * 5000]
numbers = st.one_of(st.sampled_from(EDGE_NUMBERS),
                    st.floats(allow_nan=True, allow_infinity=True).map(repr),
                    st.integers(-(10**40), 10**40).map(str),
                    st.text(max_size=6))
KEYS = sorted({k for reg in (schemes(), cases()) for c in reg.plugins.values() for k in c.params})
NAMES = sorted([*schemes().names(), *cases().names()])


@st.composite
def specs(draw: st.DrawFn) -> str:
    name = draw(st.one_of(st.sampled_from(NAMES), st.text(max_size=8)))
    if draw(st.booleans()):
        return name
    items = []
    for _ in range(draw(st.integers(0, 3))):
        key = draw(st.one_of(st.sampled_from(KEYS), st.text(max_size=4)))
        if draw(st.integers(0, 4)) == 0:  # a list, maybe with empty items
            values = draw(st.lists(st.one_of(numbers, st.just("")), max_size=3))
            items.append(f"{key}=[{','.join(values)}]")
        else:
            items.append(f"{key}={draw(numbers)}")
    sep = draw(st.sampled_from([",", ",,", ", "]))
    tail = draw(st.sampled_from(["]", "", "]]", "[]"]))
    return f"{name}[{sep.join(items)}{tail}"


def _one_line(message: str) -> None:
    assert "\n" not in message and len(message) < 2000, message[:300]


# ---------------------------------------------------------------------- specs
@_settings("spec")
@given(spec=specs())
def test_fuzz_spec_strings(spec):
    _count("spec")
    for make in (make_scheme, make_case):
        try:
            plugin = make(spec)
        except BenchError as exc:
            _one_line(str(exc))
            continue
        again = make(plugin.spec)  # what is run is what the label says, to the last digit
        assert again.values == plugin.values and again.spec == plugin.spec
    try:
        expanded = expand_spec(spec)
    except BenchError as exc:
        _one_line(str(exc))
        return
    assert expanded


# -------------------------------------------------------------------- run_one
CHEAP_CASES = ["clamped_bar", "pulse", "grazing", "rough_data"]
SMALL = [None, 2, 3, 8, 16]
BAD_INT = [-1, 0, 1, 2.5, 10**9, 10**400, float("nan"), float("inf"), "x", "", "٣", True]
GOOD_DT = [None, 0.01, 0.05]
BAD_FLOAT = [0.0, -0.0, -1.0, float("nan"), float("inf"), -float("inf"), 1e308, 5e-324,
             1e-320, 10.0, "", "abc", 10**400]


@_settings("run_one")
@given(case=st.sampled_from(CHEAP_CASES), scheme=st.sampled_from(schemes().names()),
       nx=st.sampled_from(SMALL + BAD_INT), dt=st.sampled_from(GOOD_DT + BAD_FLOAT),
       T=st.sampled_from([0.05, 0.1, *BAD_FLOAT]),
       stride=st.sampled_from([None, 1, 2, 0, -1, 10**300, 2.5, float("nan")]),
       grading=st.sampled_from([1.0, 1.5, 50.0, 1e5, float("nan"), float("inf"), 0.5, -0.0,
                                "x"]))
def test_fuzz_run_one(case, scheme, nx, dt, T, stride, grading):
    from contact_bench.harness.runner import run_one

    _count("run_one")
    try:
        run = run_one(case, scheme, nx, dt, T, stride, grading)
    except BenchError as exc:
        _one_line(str(exc))
        return
    assert run.row["status"] in {"ok", "unstable", "not applicable"}, run.row["notes"]


# ------------------------------------------------------------------------ CLI
OPTION_VALUES = {
    "--nx": st.one_of(st.sampled_from(["2", "8", "1e1", "16"]), numbers),
    "--dt": st.one_of(st.sampled_from(["0.01", "0.05"]), numbers),
    "--stride": st.one_of(st.sampled_from(["1", "2"]), numbers),
    "--grading": st.one_of(st.sampled_from(["1", "1.5"]), numbers),
    "--case": st.one_of(st.sampled_from(CHEAP_CASES), specs()),
    "--scheme": st.one_of(st.sampled_from(["standard", "penalty[gamma_p=[1,10]]"]), specs()),
    "--cfl": st.one_of(st.sampled_from(["0.5", "1"]), numbers),
    "--max-samples": st.one_of(st.sampled_from(["10"]), numbers),
    "-j": st.sampled_from(["1", "0", "-1", "x", ""]),
    "--repeats": st.sampled_from(["0", "-1", "x", ""]),
    "--format": st.sampled_from(["csv", "json", "xml", ""]),
    "--dask": st.sampled_from(["", "::::", "bogus://a:b:c"]),
    "--error": st.one_of(st.sampled_from(["err_u_linf_l2", "notes", "bogus", ""]),
                         st.text(max_size=5)),
}
RUN_OPTIONS = ["--nx", "--dt", "--stride", "--grading", "--case", "--scheme", "--format"]
SWEEP_OPTIONS = ["--nx", "--dt", "--stride", "--grading", "--case", "--scheme", "--cfl",
                 "--max-samples", "-j", "--repeats", "--dask"]


@st.composite
def command_lines(draw: st.DrawFn) -> tuple[list[str], str]:
    command = draw(st.sampled_from(["run", "sweep", "study", "report"]))
    out_kind = draw(st.sampled_from(["tmp", "tmp", "empty", "file", "long", "nul"]))
    if command == "run":
        argv = ["run", "--format", "csv", "--case", "clamped_bar"]
        options = RUN_OPTIONS
    elif command == "sweep":
        argv = ["sweep", "--quiet", "--no-cache", "-j", "1", "--repeats", "0",
                "--case", "clamped_bar"]
        options = SWEEP_OPTIONS
    elif command == "study":  # only bad inputs: a study's work is minutes
        argv = ["study", "--quick", "--quiet", "--no-cache", "-j", "1"]
        options = ["--error"]
    else:
        argv = ["report", draw(st.sampled_from(["missing.csv", "/dev/null", ""]))]
        options = ["--error"]
    T = draw(st.one_of(st.sampled_from(["0.05", "0.1"]), numbers))
    if command in {"run", "sweep"}:
        argv += ["--T", T]
    for opt in draw(st.lists(st.sampled_from(options), max_size=4)):
        argv += [opt, draw(OPTION_VALUES[opt])]
    if command == "study":  # last wins: the checks are fuzzed, a study never starts
        argv += ["--error", draw(st.sampled_from(["bogus", "", "notes", "\u00e9"]))]
    return argv, out_kind


def _out_arg(kind: str, tmp: Path) -> str:
    return {"tmp": str(tmp / "out"), "empty": "", "file": str(tmp / "afile"),
            "long": str(tmp / ("n" * 300)), "nul": str(tmp / "a\x00b")}[kind]


def _cheap(argv: list[str]) -> bool:
    """Valid runs must stay small: nx <= 16 and T <= 0.1 (else the example is skipped)."""
    from contact_bench.cli.checks import numbers as parse

    try:
        for opt, value in zip(argv, argv[1:], strict=False):
            if opt == "--nx" and any(n > 16 for n in parse([value], int, "nx", commas=True)):
                return False
            if opt == "--T" and not parse([value], float, "T")[0] <= 0.1:
                return False
            if opt == "--cfl" and any(not c >= 0.1 for c in
                                      parse([value], float, "cfl", commas=True)):
                return False
            if opt == "--dt" and any(not d >= 1e-3 for d in
                                     parse([value], float, "dt", commas=True)):
                return False
    except BenchError:
        return True  # refused before any work
    return True


@_settings("cli")
@given(line=command_lines())
def test_fuzz_command_line(line, tmp_path_factory):
    from contact_bench.cli.main import main

    argv, out_kind = line
    hypothesis.assume(_cheap(argv))
    _count("cli")
    tmp = tmp_path_factory.mktemp("fuzz")
    (tmp / "afile").write_text("x")
    argv = [*argv, "--out", _out_arg(out_kind, tmp)]
    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        try:
            code = main(argv)
        except SystemExit as exc:  # --help only
            code = exc.code
    text = err.getvalue()
    assert "Traceback" not in text, text[-2000:]
    if code == 0:
        return
    assert code == 2, (code, text[-500:])
    assert text.count("\n") == 1 and text.startswith("contact-bench: error: "), text[:500]
    assert len(text) < 2000
    assert sorted(p.name for p in tmp.iterdir()) == ["afile"], argv[:12]
