"""Peak memory of a whole `contact-bench run` process (the issue's n = 1e6 bound).

    python benchmarks/memory.py [--repeat N] [--scheme S ...]   # default: N = 3, standard

The peak is not `ru_maxrss` from os.wait4: Linux carries the high-water mark across fork
and exec, so a child started by a large process (a pytest worker, a notebook) reports at
least its parent's size. The child reads /proc/self/status instead, which belongs to the
address space that exec created.

Each configuration runs `python -m contact_bench run --case clamped_bar --scheme S --nx N
--dt 1e-7 --T 1e-4 --stride K --format csv` (1000 steps) in N fresh processes, and
prints the peak resident set size of each process (the VmHWM of its own address space,
read by the process as it exits) as the median and the largest, in MiB (2^20 bytes),
next to what grows with the problem: the stored samples of U and V (16 bytes per dof
and sample) and the n doubles of one array. The issue's bound: a run at n = 1e6 over 1000 steps with
`--stride 100` stays under 500 MB peak (the last column gives it in 10^6 bytes too:
500 MB is 476.8 MiB). The n = 1e5 and stride 50 rows show what grows
with n and with the number of samples. `--nx N` (repeatable) runs other meshes instead,
each at stride 100.
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
STEPS = 1000
CONFIGS = ((100_000, 100), (1_000_000, 100), (1_000_000, 50))  # (nx, stride)


# `python -m contact_bench ARGS`, then the process's own peak RSS (kB) on stderr's last line.
_CHILD = """
import runpy, sys
sys.argv = ["contact_bench", *sys.argv[1:]]
try:
    runpy.run_module("contact_bench", run_name="__main__", alter_sys=True)
except SystemExit as exc:
    code = exc.code
else:
    code = 0
with open("/proc/self/status") as f:
    hwm = next(line.split()[1] for line in f if line.startswith("VmHWM:"))
sys.stdout.flush()
print("VmHWM_kB", hwm, file=sys.stderr)
sys.exit(code)
"""


def peak_mb(scheme: str, nx: int, stride: int) -> float:
    """Peak RSS of one fresh `run` process, in MiB; its failure is an error."""
    cmd = [sys.executable, "-c", _CHILD, "run", "--case", "clamped_bar", "--scheme",
           scheme, "--nx", str(nx), "--dt", "1e-7", "--T", f"{STEPS * 1e-7:.12g}",
           "--stride", str(stride), "--format", "csv"]
    proc = subprocess.run(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                          text=True, check=False)
    lines = proc.stderr.strip().splitlines()
    if proc.returncode != 0 or not lines or not lines[-1].startswith("VmHWM_kB "):
        shown = " ".join(["python -m contact_bench", *cmd[3:]])
        raise SystemExit(f"{shown} failed ({proc.returncode}): {proc.stderr.strip()}")
    return int(lines[-1].split()[1]) / 1024.0


def main(argv: list[str]) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=3, help="fresh processes per row (3)")
    p.add_argument("--scheme", action="append", help="scheme specs (default: standard)")
    p.add_argument("--nx", type=int, action="append",
                   help="meshes, each at stride 100 (default: the rows of CONFIGS)")
    args = p.parse_args(argv)
    if args.repeat < 1:
        p.error(f"--repeat must be >= 1, got {args.repeat}")
    bad = [n for n in args.nx or [] if n < 1]
    if bad:
        p.error(f"--nx must be >= 1, got {bad[0]}")
    configs = [(n, 100) for n in args.nx] if args.nx else CONFIGS
    schemes = args.scheme or ["standard"]
    sys.path.insert(0, str(ROOT))
    from contact_bench.api.registry import make_scheme
    from contact_bench.core.errors import BenchError

    try:  # the registry's own check, before any process is started
        for spec in schemes:
            make_scheme(spec)
    except BenchError as exc:
        p.error(str(exc))
    print(f"{'scheme':<16} {'nx':>8} {'stride':>6} {'samples':>7} {'samples MiB':>11} "
          f"{'n doubles MiB':>13} {'peak MiB median':>15} {'max':>6} {'median 1e6 B':>12}")
    for scheme in schemes:
        for nx, stride in configs:
            peaks = [peak_mb(scheme, nx, stride) for _ in range(args.repeat)]
            samples = STEPS // stride + 1
            med = statistics.median(peaks)
            print(f"{scheme:<16} {nx:>8} {stride:>6} {samples:>7} "
                  f"{16 * samples * nx / 2**20:>11.1f} {8 * nx / 2**20:>13.1f} "
                  f"{med:>15.1f} {max(peaks):>6.1f} {med * 2**20 / 1e6:>12.1f}")
    print(f"peak RSS of each fresh process (its VmHWM), {args.repeat} per row; "
          f"clamped_bar, dt = 1e-7, {STEPS} steps")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
