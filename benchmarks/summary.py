"""Print the table of a pytest-benchmark JSON file (ns per dof-step, speedup, error).

    python -m pytest benchmarks --benchmark-autosave            # or --benchmark-json=FILE
    python benchmarks/summary.py [FILE]        # default: the newest file under .benchmarks/
    python benchmarks/summary.py --speedups FILE FILE ...   # the speedup over scipy, run by run

`--speedups`: one row per (scheme, n) of `test_speedup_over_scipy`, its speedup in each
file (a run of the suite, or of `benchmarks/test_stepping.py -k speedup`), and the
smallest, median and largest of them. One run does not tell a speedup near its target:
it moves by a few units from run to run.
"""

from __future__ import annotations

import json
import statistics
import sys
from pathlib import Path


def table(path: Path) -> str:
    data = json.loads(path.read_text())
    lines = ["| benchmark | n | steps | median s | ns/dof-step | scipy ns/dof-step | speedup "
             "| err_u_linf_l2 |", "|---|---:|---:|---:|---:|---:|---:|---:|"]
    for b in sorted(data["benchmarks"], key=lambda b: (b["name"].split("[")[0],
                                                        b["extra_info"].get("nfree", 0),
                                                        b["name"])):
        x = b["extra_info"]

        def f(key: str, fmt: str, x=x) -> str:
            return format(x[key], fmt) if x.get(key) is not None else ""

        if "ratio_standard" in x:  # benchmarks/test_norms.py: in the table below
            continue
        lines.append(f"| {b['name']} | {x.get('nfree', '')} | {x.get('nsteps', '')} "
                     f"| {b['stats']['median']:.4f} | {f('ns_per_dof_step', '.2f')} "
                     f"| {f('scipy_ns_per_dof_step', '.0f')} | {f('speedup', '.0f')} "
                     f"| {f('err_u_linf_l2', '.2e')} |")
    norms = [b for b in data["benchmarks"] if "ratio_standard" in b["extra_info"]]
    if norms:
        lines += ["", "| norms | samples | mode | norm ms | standard ms | ratio | fastest "
                  "| fastest ms | ratio |", "|---|---:|---|---:|---:|---:|---|---:|---:|"]
        for b in norms:
            x = b["extra_info"]
            st = x["stepping_s"]
            lines.append(f"| {x['case']} nx={x['nx']} dt={x['dt']:g} | {x['samples']} "
                         f"| {x['mode']} | {x['norm_s'] * 1e3:.2f} "
                         f"| {st['standard'] * 1e3:.2f} | {x['ratio_standard']:.2f} "
                         f"| {x['fastest']} | {st[x['fastest']] * 1e3:.2f} "
                         f"| {x['ratio_fastest']:.2f} |")
    return "\n".join(lines)


def speedups(paths: list[Path]) -> str:
    """The speedup over scipy of each (scheme, n) in each run, then min, median, max."""
    runs: dict[tuple[str, int], list[float | None]] = {}
    for i, path in enumerate(paths):
        try:
            found = [(b["extra_info"]["scheme"], int(b["extra_info"]["nfree"]),
                      float(b["extra_info"]["speedup"]))
                     for b in json.loads(path.read_text())["benchmarks"]
                     if b["extra_info"].get("speedup") is not None]
        except (ValueError, KeyError, TypeError) as exc:
            raise ValueError(f"{path} is not a pytest-benchmark JSON file of "
                             f"benchmarks/ ({type(exc).__name__}: {exc})") from None
        for scheme, n, speedup in found:
            runs.setdefault((scheme, n), [None] * len(paths))[i] = speedup
    if not runs:
        raise ValueError("no speedup benchmark (test_speedup_over_scipy) in "
                         + ", ".join(str(p) for p in paths))
    head = " | ".join(f"run {i + 1}" for i in range(len(paths)))
    lines = [f"| scheme | n | {head} | min | median | max |",
             "|---|---:|" + "---:|" * (len(paths) + 3)]
    for (scheme, n), vals in sorted(runs.items(), key=lambda kv: (kv[0][1], kv[0][0])):
        got = [v for v in vals if v is not None]
        cells = " | ".join("" if v is None else f"{v:.1f}" for v in vals)
        lines.append(f"| {scheme} | {n} | {cells} | {min(got):.1f} "
                     f"| {statistics.median(got):.1f} | {max(got):.1f} |")
    return "\n".join(["runs: " + ", ".join(str(p) for p in paths), "", *lines])


def main(argv: list[str]) -> int:
    if argv[:1] == ["--speedups"]:
        if len(argv) < 2:
            print("summary.py: error: --speedups needs at least one JSON file", file=sys.stderr)
            return 2
        try:
            print(speedups([Path(a) for a in argv[1:]]))
        except (OSError, ValueError) as exc:
            print(f"summary.py: error: {exc}", file=sys.stderr)
            return 2
        return 0
    if argv:
        path = Path(argv[0])
    else:
        files = sorted(Path(".benchmarks").glob("*/*.json"), key=lambda p: p.stat().st_mtime)
        if not files:
            print("no saved benchmarks under .benchmarks/", file=sys.stderr)
            return 1
        path = files[-1]
    print(f"{path}\n\n{table(path)}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
