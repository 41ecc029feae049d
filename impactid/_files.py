"""Output files: one atomic writer for every format, and the checks an output path must pass.

Every file impactid writes (JSON, TOML, CSV, PNG, HDF5) goes through :class:`StagedFiles`: each
file is written to a temporary name in its final folder (created with the permissions the user's
umask gives, like any file a program creates, not the ``0600`` of :func:`tempfile.mkstemp`) and
renamed into place only when the whole job has succeeded, so that a failure, Ctrl-C or SIGTERM
leaves the previous files untouched and no temporary file behind. Renames are atomic, so two jobs
writing the same output at once each leave a complete file (the last one wins).

:func:`check_output` is called before any computation starts: an output may never be one of the
command's inputs (compared by resolved path and by inode), never a special file (a symlink, a
named pipe, a device, a directory where a file is expected or a file where a directory is
expected), and its folder must be creatable. Problems raise :class:`OutputError` naming the option
and the path.
"""

from __future__ import annotations

import hashlib
import os
import secrets
import signal
import stat
import threading
from collections.abc import Callable, Iterable
from pathlib import Path

from impactid._signals import arrived_stop
from impactid.errors import ImpactidError

__all__ = ["DuplicateInputError", "OutputError", "StagedFiles", "TerminationRequested", "atomic_write",
           "check_distinct_inputs", "check_output", "file_mode", "request_termination", "same_file",
           "termination_requested"]


class OutputError(ImpactidError, ValueError):
    """An output path cannot be written (it is an input, a special file, not creatable, ...)."""


class DuplicateInputError(ImpactidError, ValueError):
    """The same input was given twice (by two names, or as two files with identical contents)."""


class TerminationRequested(BaseException):
    """The process was asked to stop (SIGTERM): raised by the signal handler, and again by
    :meth:`StagedFiles.commit` in case the first one landed where Python ignores exceptions (a
    finalizer), so that no output of a terminated job is ever put in place."""


#: Set by :func:`request_termination` (the CLI's SIGTERM handler).
_TERMINATION = threading.Event()


def termination_requested() -> bool:
    """Whether :func:`request_termination` was called in this process."""
    return _TERMINATION.is_set()


def request_termination() -> None:
    """Mark the process as terminating and raise :class:`TerminationRequested`."""
    _TERMINATION.set()
    raise TerminationRequested()


def file_mode() -> int:
    """Permissions of a new file under the current umask (``0o666 & ~umask``)."""
    umask = os.umask(0o022)
    os.umask(umask)
    return 0o666 & ~umask


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether two paths name the same file: equal resolved paths, or the same device and inode."""
    pa, pb = Path(a), Path(b)
    try:
        if pa.resolve() == pb.resolve():
            return True
    except (OSError, RuntimeError):
        pass
    try:
        return os.path.samefile(pa, pb)
    except OSError:
        return False


def _content_digest(path: Path, chunk: int = 1 << 20) -> str | None:
    """SHA-256 of a regular file's bytes (None when it is not a readable regular file)."""
    try:
        if not path.is_file():
            return None
        digest = hashlib.sha256()
        with open(path, "rb") as handle:
            while block := handle.read(chunk):
                digest.update(block)
        return digest.hexdigest()
    except OSError:
        return None


def check_distinct_inputs(paths: Iterable[str | os.PathLike[str]], *, what: str = "recording") -> None:
    """Refuse inputs that are the same data given twice: one file under two names (resolved path or
    inode) or two files with identical bytes (SHA-256).

    A joint fit that counts a recording twice halves its variance estimate and narrows every interval
    by a factor of about 1.4 with no new information, so a duplicate is an input error, not a warning.

    Raises
    ------
    DuplicateInputError
        naming both paths and how they were found to be the same.
    """
    given = [Path(raw) for raw in paths if raw is not None]
    for k, path in enumerate(given):
        for earlier in given[:k]:
            if same_file(earlier, path):
                raise DuplicateInputError(f"{path}: the same {what} as {earlier} (given twice); each {what} "
                                          "may be given once, or its data would count twice")
    # identical bytes: only files whose size another input shares are read and hashed
    sizes: dict[int, list[Path]] = {}
    for path in given:
        try:
            if path.is_file():
                sizes.setdefault(path.stat().st_size, []).append(path)
        except OSError:
            continue
    for group in (g for g in sizes.values() if len(g) > 1):
        digests: dict[str, Path] = {}
        for path in group:
            digest = _content_digest(path)
            if digest is None:
                continue
            if digest in digests:
                raise DuplicateInputError(f"{path}: identical contents to {digests[digest]} (SHA-256 {digest[:12]}); "
                                          f"each {what} may be given once, or its data would count twice")
            digests[digest] = path


def _first_existing_ancestor(path: Path) -> Path:
    for parent in path.absolute().parents:
        if parent.exists() or parent.is_symlink():
            return parent
    return Path(path.absolute().anchor)


def check_output(path: str | os.PathLike[str], *, option: str, inputs: Iterable[str | os.PathLike[str]] = (),
                 directory: bool = False) -> Path:
    """Check an output path before the computation starts; returns it as a :class:`Path`.

    Parameters
    ----------
    path : the output file (or folder, with ``directory=True``).
    option : the command-line option or argument that named it (for the message), e.g. ``--out``.
    inputs : the command's input files; the output may be none of them.
    directory : the output is a folder that will receive files.

    Raises
    ------
    OutputError
        naming ``option`` and ``path``: it is an input, a special file, of the wrong kind, or its
        folder cannot be created (a path under a regular file, an unwritable folder).
    """
    if str(os.fspath(path)).strip() == "":  # before Path(), which reads "" as "."
        raise OutputError(f"{option}: empty path")
    path = Path(path)
    where = f"{option} {path}"
    for source in inputs:
        if source is not None and (path.exists() or path.is_symlink()) and same_file(path, source):
            raise OutputError(f"{where}: is an input of this command ({source}); refusing to overwrite it")
    if path.is_symlink():
        raise OutputError(f"{where}: is a symbolic link; refusing to replace it (name the target itself)")
    if path.exists():
        mode = path.stat().st_mode
        if directory:
            if not stat.S_ISDIR(mode):
                raise OutputError(f"{where}: exists and is not a folder")
            folder = path
        else:
            if stat.S_ISDIR(mode):
                raise OutputError(f"{where}: is a folder, expected a file name")
            if not stat.S_ISREG(mode):
                raise OutputError(f"{where}: is a special file (named pipe, device or socket); refusing to write")
            folder = path.parent
    else:
        folder = path if directory else path.parent
    if folder.exists():
        if not folder.is_dir():
            raise OutputError(f"{where}: {folder} is not a folder")
        if not os.access(folder, os.W_OK | os.X_OK):
            raise OutputError(f"{where}: folder {folder} is not writable")
    else:
        ancestor = _first_existing_ancestor(folder)
        if not ancestor.is_dir():
            raise OutputError(f"{where}: cannot create folder {folder}: {ancestor} is not a folder")
        if not os.access(ancestor, os.W_OK | os.X_OK):
            raise OutputError(f"{where}: cannot create folder {folder}: {ancestor} is not writable")
    return path


class StagedFiles:
    """A set of output files written as one transaction.

    Use as a context manager: :meth:`stage` returns a temporary path next to the final one (the
    caller writes the file there, by any means), and on a clean exit every staged file is renamed
    into place; on an exception (including Ctrl-C and SIGTERM raised as exceptions) every
    temporary file is removed and no final file is touched.

    ``protect`` lists files that must never be replaced (the command's inputs); a final path that
    names one of them is refused when it is staged.
    """

    def __init__(self, protect: Iterable[str | os.PathLike[str]] = ()):
        self._protect = [p for p in protect if p is not None]
        self._staged: list[tuple[Path, Path]] = []

    def __enter__(self) -> StagedFiles:
        return self

    def __exit__(self, kind, value, tb) -> None:
        if kind is None:
            self.commit()
        else:
            self.rollback()

    def stage(self, final: str | os.PathLike[str]) -> Path:
        """A new empty temporary file in the folder of ``final`` (created if needed), to be renamed
        to ``final`` on commit. Its permissions follow the umask."""
        final = Path(final)
        for source in self._protect:
            if (final.exists() or final.is_symlink()) and same_file(final, source):
                raise OutputError(f"{final}: is an input of this command; refusing to overwrite it")
        if final.is_symlink() or (final.exists() and not final.is_file()):
            raise OutputError(f"{final}: exists and is not a regular file; refusing to replace it")
        try:
            final.parent.mkdir(parents=True, exist_ok=True)
        except OSError as exc:
            raise OutputError(f"{final}: cannot create folder {final.parent} ({exc.strerror})") from None
        while True:
            tmp = final.parent / f".{final.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
            try:
                fd = os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666)  # umask applies
            except FileExistsError:
                continue
            except OSError as exc:
                raise OutputError(f"{final}: cannot write ({exc.strerror})") from None
            os.close(fd)
            break
        self._staged.append((tmp, final))
        return tmp

    def write_text(self, final: str | os.PathLike[str], text: str) -> Path:
        """Stage ``final`` with ``text`` (UTF-8)."""
        return self.write_with(final, lambda tmp: tmp.write_text(text, encoding="utf-8"))

    def write_with(self, final: str | os.PathLike[str], writer: Callable[[Path], object]) -> Path:
        """Stage ``final``, written by ``writer(temporary_path)``; returns ``final`` as a Path."""
        tmp = self.stage(final)
        try:
            writer(tmp)
        except OSError as exc:
            raise OutputError(f"{final}: cannot write ({exc.strerror or exc})") from None
        return Path(final)

    def commit(self) -> list[Path]:
        """Rename every staged file into place; returns the final paths."""
        done = []
        stop = signal.SIGTERM if _TERMINATION.is_set() else arrived_stop()
        if stop is not None:  # a stop arrived, even one whose exception was lost: nothing is put in place
            self.rollback()
            if stop == signal.SIGTERM:
                raise TerminationRequested()
            raise KeyboardInterrupt()
        try:
            for tmp, final in self._staged:
                with open(tmp, "rb+") as fh:
                    os.fsync(fh.fileno())
                os.replace(tmp, final)
                done.append(final)
        except BaseException:
            self.rollback()
            raise
        self._staged = []
        return done

    def rollback(self) -> None:
        """Remove every staged temporary file (the final files are untouched)."""
        for tmp, _ in self._staged:
            try:
                tmp.unlink()
            except FileNotFoundError:
                pass
        self._staged = []


def atomic_write(path: str | os.PathLike[str], data: str | bytes | Callable[[Path], object], *,
                 protect: Iterable[str | os.PathLike[str]] = ()) -> Path:
    """Write one file atomically: text, bytes, or by ``data(temporary_path)``. Returns the path."""
    with StagedFiles(protect) as staged:
        if isinstance(data, str):
            staged.write_text(path, data)
        elif isinstance(data, bytes):
            staged.write_with(path, lambda tmp: tmp.write_bytes(data))
        else:
            staged.write_with(path, data)
    return Path(path)
