"""Atomic result files: write to a temporary file in the same folder, then rename; a set
of files (`folder_set`): write into a hidden folder beside the target, then swap it in.
A file or set written under the repository's results/ records the source hash of the
code that made it (`contact_bench.core.sources`)."""

from __future__ import annotations

import contextlib
import glob
import os
import shutil
import signal
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path

from contact_bench.core import sources

_UMASK = os.umask(0)
os.umask(_UMASK)


def atomic_write(path: str | Path, writer: Callable[[str], None]) -> Path:
    """Call writer(tmp_path), then rename onto path: a reader never sees half a file."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp: str | None = None
    try:  # everything from mkstemp on: Ctrl-C at any point removes the temporary file
        # hidden ``.<name>.<random><suffix>``: writers that infer the format still can
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=path.suffix, dir=path.parent)
        os.close(fd)
        writer(tmp)
        os.chmod(tmp, 0o666 & ~_UMASK)  # mkstemp makes 0600; results are ordinary files
        with open(tmp, "rb+") as fh:  # on disk before the rename (a crash keeps old or new)
            os.fsync(fh.fileno())
        os.replace(tmp, path)
        tmp = None
    finally:
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)
    sources.record(path)  # under results/: the code that made it (results/sources.txt)
    return path


def write_text(path: str | Path, text: str) -> Path:
    def _w(tmp: str) -> None:
        with open(tmp, "w", encoding="utf-8") as fh:
            fh.write(text)

    return atomic_write(path, _w)


#: the hidden folder a set of result files is written into before it replaces the target
PARTIAL = ".{name}.partial-{pid}-"


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # exists, owned by someone else
        return True
    return True


def _remove_stale(parent: Path, name: str) -> None:
    """Partial folders of this target left by processes that no longer run (SIGKILL)."""
    prefix = f".{name}.partial-"
    for p in parent.glob(f"{glob.escape(prefix)}*"):
        pid = p.name[len(prefix):].split("-", 1)[0]
        if pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(p, ignore_errors=True)


def _listed(folder: Path) -> set[str] | None:
    """The files a previous set's README.md lists (None: no such README)."""
    readme = folder / "README.md"
    if not readme.is_file():
        return None
    text = readme.read_text(encoding="utf-8", errors="replace")
    if not text.startswith("# Results"):
        return None
    return {line[3:-1] for line in text.splitlines()
            if line.startswith("- `") and line.endswith("`") and "/" not in line}


def _ours(folder: Path) -> bool:
    """An empty folder, or one holding only a previous set (its README.md lists the set)."""
    names = {p.name for p in folder.iterdir()}
    listed = _listed(folder)
    return not names or (listed is not None and names <= listed | {"README.md"})


@contextlib.contextmanager
def folder_set(out: str | Path) -> Iterator[Path]:
    """Write a set of result files as one: yields a hidden folder beside `out`; when the
    block ends, the set replaces `out` (an interrupted block leaves `out` as it was).

    `out` missing, empty or holding only a previous set (`_ours`): renamed aside, the new
    folder renamed in, the old one removed (Ctrl-C is held off for these renames). A
    folder holding other files is kept: the new files are moved in one by one, the
    previous set's files that the new set lacks removed, README.md last. A process killed
    meanwhile leaves its hidden `.<name>.partial-<pid>-*` folder beside `out`, removed by
    the next write of the same target.
    """
    out = Path(out)
    out.parent.mkdir(parents=True, exist_ok=True)
    _remove_stale(out.parent, out.name)
    tmp = Path(tempfile.mkdtemp(prefix=PARTIAL.format(name=out.name, pid=os.getpid()),
                                dir=out.parent))
    try:
        yield tmp
        old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            _swap_in(tmp, out)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)
        sources.record(out)  # under results/: the code that made the set
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


def _swap_in(tmp: Path, out: Path) -> None:
    os.chmod(tmp, 0o777 & ~_UMASK)  # mkdtemp makes 0700
    if not out.exists():
        os.rename(tmp, out)
        return
    if _ours(out):
        aside = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
        os.rename(out, aside / out.name)
        os.rename(tmp, out)
        shutil.rmtree(aside, ignore_errors=True)
        return
    new = sorted(p.name for p in tmp.iterdir())
    stale = (_listed(out) or set()) - set(new)
    with contextlib.suppress(FileNotFoundError):  # no README: the set is marked incomplete
        os.unlink(out / "README.md")
    for name in stale:
        with contextlib.suppress(OSError):
            os.unlink(out / name)
    for name in [n for n in new if n != "README.md"] + ["README.md"] * ("README.md" in new):
        os.replace(tmp / name, out / name)
