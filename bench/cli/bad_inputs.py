"""Every bad input we try, and the one line the user sees (the table of docs/bad-inputs.md).

    python -m contact_bench.cli.bad_inputs          # prints the Markdown table

Each entry is run through `contact_bench.cli.main.main` exactly as a user would type it; the table
shows the exit code and the stderr line. `tests/test_reliability.py` runs the same list
and checks: exit code 2, one stderr line that contains the entry's bad value, no
traceback, no file written. Out-of-range rows are generated from the declared
parameters of every registered scheme and scene, so new plugins are covered too.

Two demo scenes and one demo scheme stand in for plugins that have material
parameters or cannot run a scene; they are registered only inside `demo_plugins()`.
"""

from __future__ import annotations

import contextlib
import io
import shlex
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import numpy as np

from contact_bench.api.params import Param
from contact_bench.api.plugin import (
    BarCase,
    Case,
    Contact,
    Energy,
    Scheme,
    Stepper,
    Traits,
)
from contact_bench.api.registry import cases, schemes
from contact_bench.core.errors import shown


class DemoBar(BarCase):
    """A clamped bar with material and data parameters (demo for bad input)."""

    name = "demo_bar"
    summary = "demo: clamped bar with parameters E, rho, u0_at_0, data"
    params = {
        "E": Param(1.0, "Young modulus", low=0.0, low_open=True),
        "rho": Param(1.0, "density", low=0.0, low_open=True),
        "u0_at_0": Param(0.5, "u0(0); u0 is linear down to 0 at x = L"),
        "data": Param("ok", "'nan' makes v0 not finite", choices=("ok", "nan")),
    }
    T, nx, dt = 1.0, 20, 0.01

    def u0(self, x: np.ndarray) -> np.ndarray:
        return self.u0_at_0 * (1.0 - np.asarray(x, float))

    def v0(self, x: np.ndarray) -> np.ndarray:
        v = np.zeros_like(np.asarray(x, float))
        if self.data == "nan":
            v[v.size // 2] = np.nan
        return v


class RawBar(DemoBar):
    """A scene that computes a non-physical modulus (no declared range catches it)."""

    name = "raw_bar"
    summary = "demo: a scene whose E comes out negative"
    params = {}
    E = -1.0


class DemoFreeOnly(Scheme):
    """A scheme that needs a free far end (demo): it refuses clamped bars and integrates
    nothing (the bad-input table only shows the refusal)."""

    name = "demo_free_only"
    summary = "demo: a scheme that cannot run clamped bars"

    def traits(self, problem=None) -> Traits:
        return Traits(implicit=True, massless_contact_node=False, contact=Contact.EXACT,
                      energy=Energy.MAY_GROW)

    def prepare(self, problem, dt: float) -> Stepper:
        raise NotImplementedError("demo_free_only is a demo: it integrates nothing")

    def cannot_run(self, case: Case) -> str | None:
        if isinstance(case, BarCase) and case.far_end == "clamped":
            return "needs a free far end (demo), this scene is clamped"
        return None


DEMO_CASES: tuple[type[Case], ...] = (DemoBar, RawBar)
DEMO_SCHEMES: tuple[type[Scheme], ...] = (DemoFreeOnly,)


@contextlib.contextmanager
def demo_plugins() -> Iterator[None]:
    """Register the demo plugins in this process for the duration of the block."""
    added: list[tuple[dict, str]] = []
    try:
        for reg, classes in ((cases(), DEMO_CASES), (schemes(), DEMO_SCHEMES)):
            for cls in classes:
                if cls.name not in reg.plugins:
                    reg.plugins[cls.name] = cls
                    added.append((reg.plugins, cls.name))
        yield
    finally:
        for plugins, name in added:
            plugins.pop(name, None)


@dataclass(frozen=True)
class BadInput:
    what: str  # the kind of bad input
    argv: tuple[str, ...]  # after `contact-bench`
    bad: str  # text the error line must contain (the bad value)


BASE = ("--T", "0.1", "--format", "csv")


def _run(*extra: str, case: str = "clamped_bar", scheme: str = "standard") -> tuple[str, ...]:
    return ("run", "--case", case, "--scheme", scheme, *BASE, *extra)


def _bad_value(p: Param) -> Any:
    """A value just outside what `p` allows (None if every value is allowed)."""
    if p.choices is not None:
        if all(isinstance(c, int | float) for c in p.choices):
            return max(p.choices) + 1
        return "bogus"
    if p.kind is bool:
        return "maybe"
    if p.low is not None:
        return p.low if p.low_open else p.low - 1
    if p.high is not None:
        return p.high if p.high_open else p.high + 1
    return None


def _param_entries() -> list[BadInput]:
    """One row per distinct (kind, parameter name, allowed values) of the registered plugins."""
    out, seen = [], set()
    for kind, reg in (("scheme", schemes()), ("case", cases())):
        for name, cls in reg.plugins.items():
            if cls in DEMO_CASES or cls in DEMO_SCHEMES:
                continue
            for key, p in cls.params.items():
                bad = _bad_value(p)
                if bad is None or (kind, key, p.allowed()) in seen:
                    continue
                seen.add((kind, key, p.allowed()))
                value = f"{bad:g}" if isinstance(bad, float) else str(bad)
                spec = f"{name}[{key}={value}]"
                argv = _run(case=spec) if kind == "case" else _run(scheme=spec)
                out.append(BadInput(f"{kind} parameter out of range ({p.allowed()})", argv,
                                    f"{key}={value}"))
    return out


def bad_inputs() -> list[BadInput]:
    """The list, in the table's order (parameter rows follow the registered plugins)."""
    explicit = "redistributed[beta=0]"
    fixed = [
        BadInput("nx < 1", _run("--nx", "0"), "got 0"),
        BadInput("nx not an integer", _run("--nx", "2.5"), "'2.5'"),
        BadInput("nx not a number", _run("--nx", "ten"), "'ten'"),
        BadInput("dt = 0", _run("--dt", "0"), "got 0"),
        BadInput("dt < 0", _run("--dt", "-0.01"), "-0.01"),
        BadInput("dt NaN", _run("--dt", "nan"), "nan"),
        BadInput("dt inf", _run("--dt", "inf"), "inf"),
        BadInput("dt so small the samples do not fit in memory",
                 _run("--nx", "10000", "--dt", "1e-6"), "dt = 1e-06"),
        BadInput("a body too large for the machine's memory (refused before assembly)",
                 ("run", "--case", "disc_drop", "--scheme", "standard", "--nx", "2000"),
                 "nx = 2000"),
        BadInput("T = 0", ("run", "--case", "clamped_bar", "--scheme", "standard", "--T", "0"),
                 "got 0"),
        BadInput("T < 0", ("run", "--case", "clamped_bar", "--scheme", "standard", "--T", "-1"),
                 "-1"),
        BadInput("T NaN", ("run", "--case", "clamped_bar", "--scheme", "standard", "--T", "nan"),
                 "nan"),
        BadInput("E <= 0 (scene parameter)", _run(case="demo_bar[E=0]"), "E=0"),
        BadInput("rho <= 0 (scene parameter)", _run(case="demo_bar[rho=-1]"), "rho=-1"),
        BadInput("E <= 0 (computed by the scene)", _run(case="raw_bar"), "E = -1"),
        BadInput("u0(0) < 0 (violates the constraint)", _run(case="demo_bar[u0_at_0=-0.1]"),
                 "u0(0) = -0.1"),
        BadInput("initial data not finite", _run(case="demo_bar[data=nan]"), "nan"),
        BadInput("unknown scene", _run(case="clamped"), "'clamped'"),
        BadInput("unknown scheme", _run(scheme="redistributd"), "'redistributd'"),
        BadInput("unknown parameter", _run(scheme="standard[gama=0.6]"), "'gama'"),
        BadInput("parameter not a number", _run(scheme="standard[gamma=abc]"), "gamma=abc"),
        BadInput("malformed spec", _run(scheme="standard[gamma=0.6"), "standard[gamma=0.6"),
        *_param_entries(),
        BadInput("scheme cannot run the scene (single pair asked for)",
                 _run(scheme="demo_free_only"), "demo_free_only"),
        BadInput("explicit dt above the stability limit",
                 _run("--nx", "40", "--dt", "0.1", scheme=explicit), "dt = 0.1"),
        BadInput("stride larger than the number of steps", _run("--stride", "1000"), "1000"),
        BadInput("stride < 1", _run("--stride", "0"), "got 0"),
        BadInput("time-error 0 (not read as absent)", _run("--time-error", "0"), "got 0"),
        BadInput("time-error < 0", _run("--time-error", "-1"), "got -1"),
        BadInput("time-error not an integer", _run("--time-error", "1.5"), "'1.5'"),
        BadInput("time-error not a number", _run("--time-error", "abc"), "'abc'"),
        BadInput("grading < 1", _run("--grading", "0.5"), "0.5"),
        BadInput("unknown option (argparse)", _run("--bogus"), "--bogus"),
        BadInput("bad choice (argparse)", ("run", "--format", "xml"), "'xml'"),
        BadInput("option without its value (argparse)", ("run", "--nx"), "--nx"),
        BadInput("unknown command (argparse)", ("frobnicate",), "'frobnicate'"),
        BadInput("plugin folder that does not exist", ("run", "--plugins", "no_such_folder"),
                 "no_such_folder"),
        *_edge_value_entries(),
    ]
    return fixed


#: sweep options that keep a bad-input sweep from touching anything but its --out
SWEEP = ("sweep", "--case", "clamped_bar", "--scheme", "standard", "--quiet", "--no-cache",
         "-j", "1", "--repeats", "0")


def _run_T(*extra: str, scheme: str = "standard") -> tuple[str, ...]:
    return ("run", "--case", "clamped_bar", "--scheme", scheme, "--format", "csv", *extra)


def _edge_value_entries() -> list[BadInput]:
    """Values at the edges (infinite, hundreds of digits, subnormal, empty, very long
    names and paths): each must give a one-line error, never a traceback, an
    internal-error row or a silent change."""
    long_name = "x" * 100_000
    return [
        BadInput("integer parameter infinite", _run(scheme="nitsche[theta=inf]"), "theta=inf"),
        BadInput("integer parameter of 400 digits", _run(scheme=f"nitsche[theta={'9' * 400}]"),
                 "(400 characters)"),
        BadInput("parameter subnormal", _run(scheme="standard[beta=5e-324]"), "beta=5e-324"),
        BadInput("empty item in a list", (*SWEEP[:4], "penalty[gamma_p=[1,,2]]", *SWEEP[5:]),
                 "[1,,2]"),
        BadInput("empty list", (*SWEEP[:4], "penalty[gamma_p=[]]", *SWEEP[5:]), "gamma_p=[]"),
        BadInput("empty grid (sweep --nx '')", (*SWEEP, "--nx", ""), "--nx"),
        BadInput("name of 100,000 characters", _run(scheme=long_name), "(100000 characters)"),
        BadInput("--T empty", _run_T("--T", ""), "--T"),
        BadInput("--out empty", _run_T("--T", "0.1", "--out", ""), "--out is empty"),
        BadInput("--out an existing file", _run_T("--T", "0.1", "--out", "/dev/null"),
                 "/dev/null"),
        BadInput("--out under a file", _run_T("--T", "0.1", "--out", "/dev/null/sub"),
                 "/dev/null"),
        BadInput("--out name too long", _run_T("--T", "0.1", "--out", "o" * 300),
                 "too long"),
        BadInput("sweep --out an existing file", (*SWEEP, "--out", "/dev/null"), "/dev/null"),
        BadInput("report --out an existing file", ("report", "t.csv", "--out", "/dev/null"),
                 "/dev/null"),
        BadInput("--cache a file", (*SWEEP[:-5], "-j", "1", "--repeats", "0", "--cache",
                                    "/dev/null"), "/dev/null"),
        BadInput("--dask empty", (*SWEEP, "--dask", ""), "--dask"),
        BadInput("study --error unknown column", ("study", "--quick", "--error", "bogus",
                                                  "--no-cache", "--quiet"), "'bogus'"),
        BadInput("dt larger than T", _run_T("--T", "0.1", "--dt", "10"), "dt = 10"),
        BadInput("dt subnormal", _run_T("--T", "0.1", "--dt", "1e-320"), "got 1e-320"),
        BadInput("dt so small the steps overflow", _run_T("--T", "1", "--dt", "1e-100"),
                 "dt = 1e-100"),
        BadInput("T so large the steps overflow", _run_T("--T", "1e308"), "T = 1e+308"),
        BadInput("T beyond the runs' (and references') bound",
                 _run_T("--T", "1e6", "--dt", "0.01", "--stride", "10000"), "T = 1e+06"),
        BadInput("nx too large for memory", _run_T("--T", "0.1", "--nx", "1e9"),
                 "1000000000"),
        BadInput("nx = 1", _run_T("--T", "0.1", "--nx", "1"), "got 1"),
        BadInput("grading too strong for the mesh", _run_T("--T", "0.1", "--grading", "50"),
                 "grading = 50"),
        BadInput("grading 1e5", _run_T("--T", "0.1", "--grading", "1e5"),
                 "grading = 100000"),
        BadInput("huge stride (printed short)", _run_T("--T", "0.1", "--stride", "1e300"),
                 "stride = 1e+300"),
        BadInput("one scheme's lowered dt keeps too many samples (named)",
                 _run_T("--T", "1", "--nx", "100000", "--scheme", "redistributed[beta=0]"),
                 "redistributed[beta=0] on clamped_bar"),
        BadInput("sweep: stride larger than the steps", (*SWEEP, "--T", "0.1", "--stride",
                                                         "1000"), "1000"),
        BadInput("sweep: samples over memory", (*SWEEP, "--T", "0.1", "--nx", "10000", "--dt",
                                                "1e-6"), "dt = 1e-06"),
        BadInput("sweep: --max-samples 0", (*SWEEP, "--max-samples", "0"), "got 0"),
    ]


def try_input(argv: tuple[str, ...] | list[str]) -> tuple[int, str]:
    """Run the CLI in-process: (exit code, stderr)."""
    from contact_bench.cli.main import main

    err, out = io.StringIO(), io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(out):
        code = main(list(argv))
    return code, err.getvalue()


def markdown_table() -> str:
    from contact_bench.cli.entry import STARTING
    from contact_bench.cli.main import INTERRUPTED

    lines = ["| Bad input | Command | What the user sees (stderr) | Exit |",
             "|---|---|---|---|"]
    with demo_plugins():
        for item in bad_inputs():
            code, err = try_input(item.argv)
            cmd = shown(shlex.join(["contact-bench", *item.argv]), 200)
            seen = err.strip().replace("|", "\\|")
            lines.append(f"| {item.what} | `{cmd}` | `{seen}` | {code} |")
    lines.append(f"| Ctrl-C during a run | (SIGINT) | `{INTERRUPTED}` | 130 |")
    lines.append(f"| Ctrl-C while the modules import | (SIGINT) | `{STARTING}` | 130 |")
    lines.append("")
    lines.append("`demo_bar`, `raw_bar` and `demo_free_only` are demo plugins of "
                 "`bench/cli/bad_inputs.py`, registered only while the table is made.")
    return "\n".join(lines)


if __name__ == "__main__":
    print(markdown_table())
