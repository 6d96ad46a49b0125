"""Numba reference-counting call sites in a scheme's compiled loop, per function.

numba counts references to every array of a typed tuple each time the tuple is passed to
a compiled function (the callee takes its own reference to each array on entry, drops it
on exit) or one of its arrays is read into a variable; each count is an atomic increment
or decrement (`NRT_incref`, `NRT_decref`). This script compiles the scheme's loop on the
clamped bar (n = 20) into a fresh numba cache directory (the inspection needs a fresh
compile) and counts the calls of the two in the loop's LLVM IR, per function: a static
count (call sites, not calls made), to compare two checkouts without timing them
(docs/reference-counting.md).

    python benchmarks/nrt_sites.py laursen_love

It compiles every function the loop calls (minutes on a loaded machine).
"""

from __future__ import annotations

import argparse
import collections
import os
import re
import sys
import tempfile


def demangle(symbol: str) -> str:
    """The dotted name in numba's mangled symbol (_ZN, then length-prefixed parts)."""
    rest = symbol[3:] if symbol.startswith("_ZN") else symbol
    parts = []
    while (m := re.match(r"\d+", rest)):
        k = int(m.group())
        parts.append(rest[m.end():m.end() + k])
        rest = rest[m.end() + k:]
    return ".".join(parts) or symbol


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scheme", help="a scheme spec whose stepper has a compiled `loop`")
    ap.add_argument("--n", type=int, default=20, help="the bar's elements (default 20)")
    ap.add_argument("--top", type=int, default=12, help="functions listed (default 12)")
    args = ap.parse_args()
    os.environ["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(prefix="nrt_sites_")
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from test_stepping import CASE

    from contact_bench.api.fem import mesh_nodes
    from contact_bench.api.problem import as_problem, discretise
    from contact_bench.api.registry import make_case, make_scheme

    case, scheme = make_case(CASE), make_scheme(args.scheme)
    semi = discretise(case, mesh_nodes(case.L, args.n), scheme.mass_kind())
    dt = 0.5 * semi.hmin / semi.c_max
    limit = scheme.stability_limit(semi)
    if limit is not None:
        dt = min(dt, 0.9 * limit)
    stepper = scheme.prepare(as_problem(semi, scheme.mass_kind()), dt)
    loop = getattr(type(stepper), "loop", None)
    if loop is None:
        raise SystemExit(f"{args.scheme}: its stepper {type(stepper).__name__} has no "
                         "compiled loop")
    stepper.run(10, 10)
    sites: collections.Counter[str] = collections.Counter()
    for sig in loop.signatures:
        name = "?"
        for line in loop.inspect_llvm(sig).splitlines():
            m = re.match(r'^define .*?@"?([^"(]+)"?\(', line)
            if m:
                name = demangle(m.group(1))
            if re.search(r"call void @NRT_(incref|decref)", line):
                sites[name] += 1
    print(f"{args.scheme} n {args.n}: {sum(sites.values())} NRT_incref/NRT_decref call "
          "sites in its loop's IR")
    for name, k in sites.most_common(args.top):
        print(f"{k:6d}  {name}")


if __name__ == "__main__":
    main()
