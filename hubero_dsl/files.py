"""Files from strangers: bounded reads of regular files only, and outputs that overwrite nothing
they should not.

A scenario names its map, and a map its image: either may point at a device (`/dev/zero` reads
for ever), a FIFO (blocks), a directory, or a huge file. `read_bounded` reads only regular files
and at most a given number of bytes; `check_output` refuses to write over anything but a
regular file, and over the files a command reads; `refuse_other_kind` over a file of
another kind than the one written (a user's CSV named as a log); `write_replacing` writes an
output beside its name and renames it into place, so that a failure never leaves a partial file
there; `scratch_folder_beside` does so for outputs of several files (a map, a bag);
`stops_held` keeps Ctrl-C and SIGTERM from landing between a file's creation and its name
being known to whoever removes it.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import stat
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

from hubero_dsl.errors import InputError

Failure = Callable[[str], Exception]


def regular_file(path: Path, what: str, failure: Failure = InputError) -> None:
    """Raise `failure` unless `path` is an existing regular file (links followed)."""
    try:
        mode = path.stat().st_mode
    except FileNotFoundError:
        raise failure(f"{what} not found: {path}") from None
    except OSError as exc:
        raise failure(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    if stat.S_ISDIR(mode):
        raise failure(f"{what} {path} is a directory, not a file")
    if not stat.S_ISREG(mode):
        raise failure(f"{what} {path} is not a regular file (a device, a FIFO or a socket)")


def read_bounded(path: Path, limit: int, what: str, failure: Failure = InputError) -> bytes:
    """The bytes of a regular file of at most `limit` bytes."""
    regular_file(path, what, failure)
    try:
        with path.open("rb") as stream:
            data = stream.read(limit + 1)
    except OSError as exc:
        raise failure(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    if len(data) > limit:
        raise failure(f"{what} {path} is larger than {_size(limit)}, the most hubero reads")
    return data


PNG_MAGIC = b"\x89PNG\r\n\x1a\n"   # how every PNG file starts
GIF_MAGIC = b"GIF8"                 # how every GIF file starts (GIF87a, GIF89a)
MCAP_MAGIC = b"\x89MCAP0\r\n"        # how every MCAP file starts (and ends)


def refuse_other_kind(path: Path, magic: bytes, kind: str, advice: str) -> None:
    """Refuse (InputError) to write over a regular file at `path` that does not start as a
    file of `kind` does (its `magic` bytes): a log is written over a log, a picture over a
    picture, a user's file never. Nothing but a regular file is opened (a FIFO would block);
    folders and devices are `check_output`'s to refuse."""
    if not path.is_file():
        return
    try:
        with path.open("rb") as stream:
            same_kind = stream.read(len(magic)) == magic
    except OSError:
        same_kind = False
    if not same_kind:
        raise InputError(f"{path} exists and is not {kind}: not writing over it ({advice})")


def check_output(path: Path, reads: Sequence[Path] = (),
                 message: Callable[[Path, str], str] | None = None) -> None:
    """Refuse (InputError) an output path in a folder that does not exist, or that is a
    directory, a device, a FIFO or a socket, or one of the files the command reads.
    `message(path, reason)` words the error (default: `PATH: cannot be written (REASON)`)."""
    problem = _output_problem(path, reads)
    if problem is not None:
        word = message or (lambda where, reason: f"{where}: cannot be written ({reason})")
        raise InputError(word(path, problem))


def check_output_folder(out_dir: Path, what: str) -> None:
    """InputError for an output folder that is a file, or that cannot be made or written in
    (the nearest folder that exists, itself or above it, is not writable): found before any
    work starts (a sweep's or a bench's workers), rather than as the folder is made."""
    existing = out_dir
    while not existing.exists() and existing != existing.parent:
        existing = existing.parent
    if existing.exists() and not existing.is_dir():
        raise InputError(f"cannot write {what} into {out_dir}: {existing} is a file, not a "
                         "directory")
    if not os.access(existing, os.W_OK | os.X_OK):
        raise InputError(f"cannot write {what} into {out_dir}: {existing} is not writable")


def _output_problem(path: Path, reads: Sequence[Path]) -> str | None:
    parent = path.parent
    if not parent.is_dir():
        return f"{parent} is not a directory" if parent.exists() else f"{parent} does not exist"
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return None
    except OSError as exc:
        return str(exc.strerror or exc)
    if stat.S_ISDIR(mode):
        return "it is a directory"
    if not stat.S_ISREG(mode):
        return "it is not a regular file: a device, a FIFO or a socket"
    for source in reads:
        try:
            if path.samefile(source):
                return "it is an input of this command"
        except OSError:
            continue
    return None


def _size(count: int) -> str:
    return f"{count / 2**20:g} MiB" if count >= 2**20 else f"{count / 2**10:g} KiB"


def write_replacing(path: Path, write: Callable[[Path], object],
                    failure: Failure = InputError) -> Path:
    """Write `path` through `write(temp)`, a temporary file beside it (same suffix, so writers
    that go by it still do), then rename it over `path`; `failure` for an OS error, and no
    temporary file left behind either way."""
    temp = path.with_name(f".{path.name}.{os.getpid()}.tmp{path.suffix}")
    try:
        write(temp)
        os.replace(temp, path)
    except OSError as exc:
        raise failure(_cannot_write(path, exc)) from None
    finally:
        with contextlib.suppress(OSError):
            temp.unlink()
    return path


STOPS = frozenset({signal.SIGINT, signal.SIGTERM})


@contextlib.contextmanager
def stops_held(stops: frozenset[signal.Signals] = STOPS) -> Iterator[None]:
    """Ctrl-C and SIGTERM (or `stops`) held back for the block, where the platform can, and
    delivered as it ends: a stop arriving just after a temporary file is created, or while a
    child process starts, would otherwise leave the file behind, or run this process's
    handler in the child. A child started in the block inherits the mask, so it must set
    its own (or ignore the signals) before it unblocks them."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    held = signal.pthread_sigmask(signal.SIG_BLOCK, stops)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, held)


@contextlib.contextmanager
def scratch_folder_beside(target: Path, shown: Path | None = None) -> Iterator[Path]:
    """A temporary folder beside `target`, to write an output of several files in before they
    are renamed into place; removed after. An OS error (a read-only folder, a full disk) is an
    InputError naming the output asked for (`shown`, else `target`), not the folder."""
    try:
        work = Path(tempfile.mkdtemp(prefix=f".{target.name}.", dir=target.parent))
    except OSError as exc:
        raise InputError(_cannot_write(shown or target, exc)) from None
    try:
        yield work
    except OSError as exc:
        raise InputError(_cannot_write(shown or target, exc)) from None
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _cannot_write(path: Path, exc: OSError) -> str:
    return f"{path}: cannot be written ({exc.strerror or exc})"


def distinct_files(paths: Sequence[str]) -> list[str]:
    """Each file once, however it is written (`a.hub`, `./a.hub`), as first written; a path
    that names no file is kept as written, to be reported."""
    first: dict[object, str] = {}
    for path in paths:
        try:
            found = os.stat(path)
        except (OSError, ValueError):
            first.setdefault(path, path)
        else:
            first.setdefault((found.st_dev, found.st_ino), path)
    return list(first.values())
