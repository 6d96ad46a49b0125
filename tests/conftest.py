"""Shared fixtures of the test suite."""

from __future__ import annotations

import sys
from collections.abc import Callable, Sequence

import pytest

#: run as `python -c RESET argv...`: SIGINT back to its default action, then exec argv
RESET_SIGINT = ("import os, signal, sys; signal.signal(signal.SIGINT, signal.SIG_DFL); "
                "os.execv(sys.argv[1], sys.argv[1:])")


@pytest.fixture
def from_a_terminal() -> Callable[[Sequence[str]], list[str]]:
    """argv -> the argv that starts it as a terminal's foreground job would: with SIGINT
    at its default action. A process started in the background of a non-interactive
    shell (`pytest ... &`) ignores SIGINT, its children inherit that, and Python then
    installs no KeyboardInterrupt handler: a Ctrl-C test would see the job run on."""

    def wrap(argv: Sequence[str]) -> list[str]:
        return [sys.executable, "-c", RESET_SIGINT, *argv]

    return wrap


@pytest.fixture(autouse=True)
def _fresh_kept_data():
    """Each test starts without the meshes and problems an earlier test kept
    (`contact_bench.api.kept.Kept`): a test that changes a scene sees its own."""
    from contact_bench.api.kept import Kept

    Kept.clear_all()
    yield

