"""Checks of the command line's inputs made before any work: numbers, output folders, Dask.

Every failure is a one-line `BenchError` naming the bad value (exit 2), raised before a
run starts or a file is written, so a bad `--out` is not found after an hour of runs.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

from contact_bench.core.errors import BenchError, shown, shown_repr

_ALLOWED = {"nx": "an integer >= 2", "dt": "a number > 0", "T": "a number > 0",
            "cfl": "a number > 0", "stride": "an integer >= 1", "max-samples": "an integer >= 1",
            "time-error": "an integer >= 2"}
#: longest path the CLI accepts (Linux PATH_MAX)
PATH_MAX = 4096


def numbers(values: list[str] | None, kind: type, name: str,
            commas: bool = False) -> list[int | float] | None:
    """Parse option values (`run` and `sweep` alike: 1e3 is an integer); ranges are checked by
    the harness. With `commas`, each value may hold several, "10,20". An empty item is an
    error, not skipped; None (option absent) gives None."""
    if values is None:
        return None
    out: list[int | float] = []
    for raw in values:
        for v in (raw.split(",") if commas else [raw]):
            text = v.strip()
            try:
                if not text:
                    raise ValueError
                if kind is float:
                    x: float | int = float(text)
                else:
                    try:
                        x = int(text)
                    except ValueError:
                        f = float(text)  # 1e3 is an integer too
                        if not f.is_integer():
                            raise
                        x = int(f)
            except (ValueError, OverflowError):
                what = "an empty value" if not text else shown_repr(v)
                raise BenchError(f"--{name} must be {_ALLOWED.get(name, kind.__name__)}, "
                                 f"got {what}") from None
            out.append(x)
    return out


def positive_int(value: int | None, name: str) -> None:
    """An optional count option (e.g. --max-samples): absent, or >= 1."""
    if value is not None and value < 1:
        raise BenchError(f"--{name} must be {_ALLOWED.get(name, 'an integer >= 1')}, "
                         f"got {value}")


def time_error_factor(value: str | None) -> int:
    """--time-error K: absent gives 0 (no time-error columns); given, K must be an integer
    >= 2 (the reference runs at dt / K), so 0, -1, 1.5 and 'abc' are refused, not read as
    absent."""
    if value is None:
        return 0
    k = int(numbers([value], int, "time-error")[0])
    if k < 2:
        raise BenchError(f"--time-error must be {_ALLOWED['time-error']}, got {k}")
    return k


def _name_max(folder: Path) -> int:
    try:
        return int(os.pathconf(folder, "PC_NAME_MAX"))
    except (OSError, ValueError):
        return 255


def out_folder(path: str | None, option: str = "--out") -> Path:
    """Check that `path` is, or can be made, a writable folder; nothing is created.

    Refused: an empty name, an existing file (or /dev/null), a parent that is a file, a
    name or path too long, a folder (or its nearest existing parent) not writable.
    """
    if path is None or not str(path).strip():
        raise BenchError(f"{option} is empty; give a folder")
    text = str(path)
    if "\0" in text:
        raise BenchError(f"{option} {shown_repr(text)}: a folder name cannot hold a NUL byte")
    if len(os.fsencode(text)) > PATH_MAX:
        raise BenchError(f"{option} {shown_repr(text)}: path too long "
                         f"({len(os.fsencode(text))} bytes; at most {PATH_MAX})")
    out = Path(text)
    missing: list[str] = []
    probe = out
    while True:
        try:
            exists = probe.exists()
        except OSError as exc:  # e.g. a name too long for the file system
            raise BenchError(f"{option} {shown_repr(text)}: {exc.strerror or exc}") from None
        if exists or probe == probe.parent:
            break
        missing.append(probe.name)
        probe = probe.parent
    if not probe.is_dir():
        what = "exists and is not a folder" if probe == out else f"has a parent {probe} " \
            "that is not a folder"
        raise BenchError(f"{option} {shown_repr(text)} {shown(what)}")
    limit = _name_max(probe)
    for part in missing:
        if len(os.fsencode(part)) > limit:
            raise BenchError(f"{option} {shown_repr(text)}: a name is too long "
                             f"({len(os.fsencode(part))} bytes; at most {limit})")
    if not os.access(probe, os.W_OK | os.X_OK):
        where = "" if probe == out else f" (its parent {probe})"
        raise BenchError(f"{option} {shown_repr(text)}{where} is not writable")
    return out


DASK_TIMEOUT_S = 5.0


def dask_address(address: str | None) -> None:
    """Check --dask before any work: 'local' needs distributed installed; an address must
    answer within DASK_TIMEOUT_S."""
    if address is None:
        return
    if not address.strip():
        raise BenchError("--dask is empty; give a scheduler address or 'local'")
    try:
        from distributed import Client
    except ImportError:
        raise BenchError("--dask needs dask distributed: "
                         "pip install 'contact-bench[dask]'") from None
    if address == "local":
        return
    try:
        client = Client(address, timeout=f"{DASK_TIMEOUT_S}s")
    except Exception as exc:  # noqa: BLE001 - any failure to connect is one line
        why = " ".join(f"{type(exc).__name__}: {exc}".split())
        raise BenchError(f"--dask {shown_repr(address)}: no scheduler answered within "
                         f"{DASK_TIMEOUT_S:g} s ({shown(why)})") from None
    client.close()


def finite_or_none(value: float | None, name: str) -> None:
    """A float option given to argparse as type=float: refuse nan and inf up front."""
    if value is not None and not math.isfinite(value):
        raise BenchError(f"--{name} must be finite, got {value!r}")
