"""Numerical references computed once, visibly: a scene's declared fine run
(`contact_bench.api.reference_run.ReferenceRun`) computed by the harness, kept on disk
and read back by every later run that asks for the same one.

Key: the SHA-256 of the scene (class, spec, attributes), the request (scheme, nx, dt,
steps, stride, the kept dofs) and a code hash: the sources of the scene's and the
reference scheme's modules, of every module of the layers a run goes through
(`contact_bench.core`, `.api`, `.kernels`, `.exact`) and of this module. Editing any of
them gives a new key, so a stale reference is never served.

Where: `reference_cache_dir()`: $CONTACT_BENCH_REFERENCE_CACHE (a folder; "off": no
disk cache), else the run cache's folder (`$CONTACT_BENCH_CACHE`, else
$XDG_CACHE_HOME/contact-bench or ~/.cache/contact-bench) + "/references": a user
folder, never inside the repository, so `git status` stays clean. One `.npz` per key
(the samples and a JSON header with the key, the cost and the description), written
atomically; an entry that does not load or holds another key is computed again.

Within a process the last references are also kept in memory (`KEEP_BYTES`), so a table
that compares several schemes reads the file once. `computed` counts the references this
process computed (not read back): a test's witness that the cache serves them.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import os
import pkgutil
import sys
import time
from dataclasses import replace
from functools import cache
from pathlib import Path

import numpy as np
from numba.core import event as numba_event

from contact_bench.api.kept import Kept
from contact_bench.api.plugin import Case
from contact_bench.api.reference_run import ReferenceRun, ReferenceSamples
from contact_bench.api.registry import make_scheme
from contact_bench.harness.io import atomic_write
from contact_bench.kernels.stepper import run_keeping

#: the layers whose every module counts in the code hash
CODE_LAYERS = ("contact_bench.core", "contact_bench.api", "contact_bench.kernels",
               "contact_bench.exact")
#: references kept in memory for the next runs of the process, in bytes (the last one
#: is always kept)
KEEP_BYTES = 256 * 2**20
#: the references computed (not read back) by this process
computed: list[str] = []

#: the references of the last runs, by key (the most recent kept whatever its size)
MEMORY: Kept[ReferenceSamples] = Kept("numerical references", max_items=64,
                                      max_bytes=KEEP_BYTES, keep_last=True)


def reference_cache_dir() -> Path | None:
    """Where references are stored (module docstring); None: not on disk."""
    own = os.environ.get("CONTACT_BENCH_REFERENCE_CACHE")
    if own:
        return None if own.strip().lower() in {"off", "none", "0", "no"} else Path(own)
    if os.environ.get("CONTACT_BENCH_CACHE"):
        return Path(os.environ["CONTACT_BENCH_CACHE"]) / "references"
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "contact-bench" / "references"


@cache
def code_hash(*module_names: str) -> str:
    """SHA-256 (16 hex digits) over the sources of these modules, of every module of
    `CODE_LAYERS` and of this one."""
    names = set(module_names) | {__name__}
    for layer in CODE_LAYERS:
        pkg = importlib.import_module(layer)
        names |= {f"{layer}.{info.name}" for info in pkgutil.iter_modules(pkg.__path__)}
    digest = hashlib.sha256()
    for name in sorted(names):
        module = sys.modules.get(name) or importlib.import_module(name)
        file = getattr(module, "__file__", None)
        digest.update(name.encode())
        if file and os.path.exists(file):
            digest.update(Path(file).read_bytes())
    return digest.hexdigest()[:16]


def reference_key(case: Case, request: ReferenceRun) -> str:
    """The key of a scene's reference run (module docstring)."""
    scheme = make_scheme(request.scheme)
    code = code_hash(type(case).__module__, type(scheme).__module__)
    blob = json.dumps({"case": f"{type(case).__module__}.{type(case).__qualname__}",
                       "spec": case.spec, "attributes": repr(sorted(vars(case).items())),
                       "run": request.inputs(), "code": code}, sort_keys=True, default=str)
    return hashlib.sha256(blob.encode()).hexdigest()


def compute(case: Case, request: ReferenceRun) -> ReferenceSamples:
    """Run the request: the scene's problem at request.nx with the scheme's mass (the
    run's: `contact_bench.harness.runner.problem_for`), the
    scheme prepared once and stepped, only the kept dofs' samples held
    (`contact_bench.kernels.stepper.run_keeping`). `seconds`: problem, set-up and
    stepping, JIT compilation excluded."""
    from contact_bench.harness.runner import compile_seconds, problem_for  # imports this

    scheme = make_scheme(request.scheme)
    with numba_event.install_recorder("numba:compile") as compiled:
        start = time.perf_counter()
        problem = problem_for(case, scheme, int(request.nx), float(request.grading),
                              keep=False)  # a finer problem: its memory goes with it
        stepper = scheme.prepare(problem, float(request.dt))
        traj = run_keeping(stepper, int(request.nsteps), int(request.stride), request.keep)
        elapsed = time.perf_counter() - start
    del stepper
    computed.append(request.label or request.scheme)
    return ReferenceSamples(
        t=traj.t, U=traj.U, U_absmax=traj.extra["U_absmax"], stress=traj.stress,
        contact_measure=float(np.sum(getattr(problem.contact, "weights", 1.0))),
        ndofs=int(problem.nfree),
        seconds=max(0.0, elapsed - compile_seconds(compiled.buffer)),
        description=request.label)


def _path(root: Path, key: str) -> Path:
    return root / key[:2] / f"{key}.npz"


def _load(path: Path, key: str) -> ReferenceSamples | None:
    """The entry at path if it is one and holds key, else None."""
    try:
        with np.load(path, allow_pickle=False) as data:
            head = json.loads(str(data["header"]))
            if head.get("key") != key:
                return None
            return ReferenceSamples(
                t=data["t"], U=data["U"], U_absmax=data["U_absmax"], stress=data["stress"],
                contact_measure=float(head["contact_measure"]), ndofs=int(head["ndofs"]),
                seconds=float(head["seconds"]), description=str(head["description"]),
                cached=True)
    except FileNotFoundError:
        return None
    except (OSError, ValueError, KeyError, TypeError):  # damaged: computed again
        print(f"contact-bench: note: reference cache entry {path} not readable; "
              "computed again", file=sys.stderr)
        return None


def _store(path: Path, key: str, ref: ReferenceSamples) -> None:
    header = json.dumps({"key": key, "contact_measure": ref.contact_measure,
                         "ndofs": ref.ndofs, "seconds": ref.seconds,
                         "description": ref.description})

    def write(tmp: str) -> None:
        with open(tmp, "wb") as fh:
            np.savez(fh, t=ref.t, U=ref.U, U_absmax=ref.U_absmax, stress=ref.stress,
                     header=np.array(header))

    try:
        atomic_write(path, write)
    except OSError as exc:  # a read-only cache folder: the reference is still used
        print(f"contact-bench: note: reference not stored in {path.parent} ({exc.strerror})",
              file=sys.stderr)


def reference_samples(case: Case, request: ReferenceRun) -> ReferenceSamples:
    """The samples of a scene's reference run: from memory, else from the disk cache,
    else computed (and stored). `cached` says which; `seconds` is always what computing
    it took."""
    key = reference_key(case, request)
    kept = MEMORY.get(key)
    if kept is not None:
        return replace(kept, cached=True)
    root = reference_cache_dir()
    ref = None if root is None else _load(_path(root, key), key)
    if ref is None:
        ref = compute(case, request)
        if root is not None:
            _store(_path(root, key), key, ref)
    return MEMORY.put(key, ref)


def forget() -> None:
    """Drop the references kept in memory (the disk cache stays)."""
    MEMORY.clear()


__all__ = ["compute", "computed", "forget", "reference_cache_dir", "reference_key",
           "reference_samples"]
