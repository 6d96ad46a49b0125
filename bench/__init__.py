"""contact-bench: a benchmark suite for numerical schemes of elastodynamic impact.

The package's layers, bottom to top (each imports only the ones below it):

- `contact_bench.core`: compiled machinery shared by kernels and norms (SIMD vectors,
  tridiagonal and SPIKE solves, sampling, energy, the blow-up rule); imports nothing of
  the project.
- `contact_bench.api`: the plugin contract (`Case`, `Scheme`, `Semidiscrete`,
  `Trajectory`, `Traits`, `Param`), the registry and the scikit-fem assembly.
- `contact_bench.kernels` (stepping kernels shared by schemes) and
  `contact_bench.exact` (exact solutions and their fast evaluators).
- `contact_bench.harness` (runs and metrics), `contact_bench.sweeps` (sweeps, cache,
  study, analysis), `contact_bench.output` (reports and figures), `contact_bench.cli`.

Plugins live in `contact_bench.schemes` and `contact_bench.cases` (the repository's
`schemes/` and `cases/` folders), in installed distributions (entry points) and in plugin
folders (loaded as `contact_bench.plugins.<name>`); they use only public names of the
layers below (`contact_bench.api` re-exports what a plugin needs; docs/plugin-api.md).
"""

def __getattr__(name: str) -> str:
    """`__version__`, read from the installed metadata when asked (importing the package
    imports nothing, so a Ctrl-C at start-up lands in the guarded entry point)."""
    if name != "__version__":
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("contact-bench")
    except PackageNotFoundError:  # pragma: no cover - running from a source tree
        return "0+unknown"
