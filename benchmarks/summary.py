"""Print the table of a pytest-benchmark JSON file (ns per dof-step, speedup, error).

    python -m pytest benchmarks --benchmark-autosave            # or --benchmark-json=FILE
    python benchmarks/summary.py [FILE]        # default: the newest file under .benchmarks/
"""

from __future__ import annotations

import json
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


def main(argv: list[str]) -> int:
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
