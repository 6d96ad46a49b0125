"""Runs and metrics: one (case, scheme, nx, dt) configuration to one metrics row.

`run_one` and `run_table` are the entry points; `reference` gives a case's exact solution,
kept for the next runs.
"""

from contact_bench.harness.runner import (
    BASE_COLUMNS,
    Run,
    reference,
    run_one,
    run_table,
    table_columns,
)

__all__ = ["BASE_COLUMNS", "Run", "reference", "run_one", "run_table", "table_columns"]
