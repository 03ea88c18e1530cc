"""File helpers shared by every file format: clear errors, atomic writes, photographs,
and output folders that are either written whole or not at all.

A command that writes checks its ``--out`` before any work
(:func:`check_output_folder`, :func:`check_output_file`), then writes into a
temporary folder that is moved into place only when everything is written
(:func:`output_folder`): a failure leaves nothing half-written behind.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from unseeable.errors import InputError

__all__ = ["read_json", "write_json", "check_format", "atomic_write_bytes", "require", "read_image",
           "check_output_folder", "check_output_file", "output_folder", "StagedFolder"]


def read_json(path: str | Path) -> Any:
    """Parse a JSON file; a missing or malformed file raises :class:`InputError` naming it."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise InputError("no such file", file=p) from None
    except IsADirectoryError:
        raise InputError("is a folder, not a JSON file", file=p) from None
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(f"cannot be read: {err}", file=p) from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as err:
        raise InputError(f"is not valid JSON: {err.msg} at line {err.lineno} column {err.colno}",
                         file=p) from None


def check_format(data: Any, expected: str, *, file: Any = None, field: str = "format") -> None:
    """Check the ``format`` tag of a parsed JSON object."""
    if not isinstance(data, dict):
        raise InputError(f"must be a JSON object with format {expected!r}", file=file,
                         value=type(data).__name__)
    if "format" not in data:
        raise InputError(f"is missing (expected {expected!r})", file=file, field=field)
    if data["format"] != expected:
        raise InputError(f"must be {expected!r}", file=file, field=field, value=data["format"])


def require(data: dict, key: str, *, file: Any = None, prefix: str = "") -> Any:
    """``data[key]`` or an :class:`InputError` saying the field is missing."""
    if not isinstance(data, dict) or key not in data:
        raise InputError("is missing", file=file, field=f"{prefix}{key}")
    return data[key]


def _default(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, Path):
        return str(obj)
    raise TypeError(f"not JSON serialisable: {type(obj).__name__}")


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file, so no half-written file is left."""
    p = Path(path)
    p.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{p.name}.", dir=p.parent)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
        # mkstemp creates 0600; give the file the mode a plain open() would.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, p)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def write_json(path: str | Path, data: Any, *, indent: int | None = 2) -> None:
    """Write ``data`` as JSON atomically (numpy values converted)."""
    text = json.dumps(data, indent=indent, default=_default)
    atomic_write_bytes(path, (text + "\n").encode("utf-8"))


def read_image(path: str | Path) -> np.ndarray:
    """Read a photograph as ``(H, W, 3) uint8`` RGB (alpha dropped, grey expanded).

    Raises
    ------
    InputError
        When the file is missing or is not an image.
    """
    from PIL import Image, UnidentifiedImageError

    p = Path(path)
    try:
        with Image.open(p) as im:
            return np.asarray(im.convert("RGB"), dtype=np.uint8).copy()
    except FileNotFoundError:
        raise InputError("no such image file", file=p) from None
    except (UnidentifiedImageError, OSError) as err:
        raise InputError(f"cannot be read as an image: {err}", file=p) from None


# ---- outputs ------------------------------------------------------------------------------

#: Name prefix of the temporary folders outputs are written in before they are moved into
#: place (left behind only when the process is killed).
STAGING_PREFIX = ".unseeable-partial-"


def _exists(path: Path, *, field: str) -> bool:
    try:
        return path.exists()
    except OSError as err:  # e.g. a folder on the way that cannot be searched
        raise InputError(f"cannot be checked: {err.strerror}", field=field,
                         value=str(path)) from None


def _writable_folder(path: Path) -> bool:
    return os.access(path, os.W_OK | os.X_OK)


def _nearest_existing(path: Path, *, field: str) -> Path:
    """The nearest ancestor of ``path`` that exists (``path`` itself does not)."""
    here = path.absolute()
    while not _exists(here, field=field):
        if here.is_symlink():  # a link to nowhere: creating through it would surprise
            raise InputError(f"cannot be made: {here} is a broken link", field=field,
                             value=str(path))
        here = here.parent
    return here


def _check_can_make(path: Path, *, field: str, value: str) -> None:
    """``path`` (which does not exist) can be made: its nearest existing ancestor is a
    folder you can write to."""
    base = _nearest_existing(path, field=field)
    if not base.is_dir():
        raise InputError(f"cannot be made: {base} is a file, not a folder", field=field,
                         value=value)
    if not _writable_folder(base):
        raise InputError(f"cannot be made: you cannot write to {base}", field=field,
                         value=value)


def check_output_folder(path: str | Path, *, field: str = "--out") -> Path:
    """Check, before any work, that ``path`` can receive a command's files.

    It must be a folder you can write to, or not exist yet with its nearest
    existing ancestor a folder you can write to.

    Parameters
    ----------
    path : path
    field : str
        The option named in the error.

    Returns
    -------
    Path

    Raises
    ------
    InputError
        Naming ``field`` and the path: a file where a folder is needed, a file
        on the way to it, or a folder that cannot be written to.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> f = pathlib.Path(tempfile.mkdtemp()) / "a-file"
    >>> _ = f.write_text("x")
    >>> check_output_folder(f)
    Traceback (most recent call last):
    ...
    unseeable.errors.InputError: --out: is a file; give a folder (got '...')
    """
    p = Path(path)
    if _exists(p, field=field):
        if not p.is_dir():
            raise InputError("is a file; give a folder", field=field, value=str(p))
        if not _writable_folder(p):
            raise InputError("is a folder you cannot write to", field=field, value=str(p))
        return p
    _check_can_make(p, field=field, value=str(p))
    return p


def check_output_file(path: str | Path, *, field: str = "--out") -> Path:
    """Check, before any work, that a file can be written at ``path``: it is not a folder,
    and its folder is one you can write to, or can be made.

    Raises
    ------
    InputError
        Naming ``field`` and the path.
    """
    p = Path(path)
    if _exists(p, field=field) and p.is_dir():
        raise InputError("is a folder; give a file name", field=field, value=str(p))
    parent = p.absolute().parent
    if _exists(parent, field=field):
        if not parent.is_dir():
            raise InputError(f"cannot be made: {parent} is a file, not a folder",
                             field=field, value=str(p))
        if not _writable_folder(parent):
            raise InputError(f"cannot be written: you cannot write to {parent}", field=field,
                             value=str(p))
    else:
        _check_can_make(parent, field=field, value=str(p))
    return p


@dataclass(frozen=True)
class StagedFolder:
    """Where a command writes its files (:attr:`path`, a temporary folder) and where they
    end up (:attr:`target`) once :func:`output_folder` moves them there."""

    path: Path
    target: Path

    def final(self, path: str | Path) -> Path:
        """Where a file written at ``path`` (inside :attr:`path`) will be."""
        p = Path(path)
        try:
            return self.target / p.relative_to(self.path)
        except ValueError:
            return p


def _is_inside(filename: Any, folder: Path) -> bool:
    if not filename:
        return False
    try:
        Path(os.fsdecode(filename)).absolute().relative_to(folder.absolute())
    except ValueError:
        return False
    return True


def _move_into(source: Path, target: Path) -> None:
    """Move every entry of folder ``source`` into folder ``target``, replacing files of the
    same name; the clashes (a folder where a file goes, or the reverse) are checked first,
    so that nothing moves when one would fail."""
    entries = sorted(source.iterdir())
    for entry in entries:
        dest = target / entry.name
        if dest.exists() and dest.is_dir() != entry.is_dir():
            raise InputError(f"cannot replace {dest}: it is a "
                             f"{'folder' if dest.is_dir() else 'file'}", field="--out",
                             value=str(target))
    for entry in entries:
        dest = target / entry.name
        if entry.is_dir() and dest.is_dir():
            _move_into(entry, dest)
            entry.rmdir()
        else:
            os.replace(entry, dest)


@contextmanager
def output_folder(path: str | Path, *, field: str = "--out") -> Iterator[StagedFolder]:
    """Write a command's files whole or not at all.

    Checks ``path`` (:func:`check_output_folder`) on entry, then yields a
    :class:`StagedFolder` whose ``path`` is a new temporary folder: beside
    ``path`` when it does not exist yet (it is renamed into place at the end),
    inside it when it does (the new files are moved in only at the end,
    replacing files of the same name and leaving the others). When the body
    raises, the temporary folder and any folder made on the way are removed
    and ``path`` is as it was.

    An ``OSError`` on a file inside the temporary folder (a full disk, say)
    becomes an :class:`InputError` naming ``field``.

    Examples
    --------
    >>> import tempfile, pathlib
    >>> out = pathlib.Path(tempfile.mkdtemp()) / "results"
    >>> with output_folder(out) as folder:
    ...     _ = (folder.path / "a.txt").write_text("done")
    >>> sorted(p.name for p in out.iterdir())
    ['a.txt']
    """
    target = Path(path)
    check_output_folder(target, field=field)
    made: list[Path] = []
    exists = target.is_dir()
    try:
        if exists:
            parent = target
        else:
            parent = target.absolute().parent
            missing = []
            here = parent
            while not here.exists():
                missing.append(here)
                here = here.parent
            for folder in reversed(missing):
                folder.mkdir()
                made.append(folder)
        staging = Path(tempfile.mkdtemp(prefix=STAGING_PREFIX if exists
                                        else f".{target.name}.partial-", dir=parent))
    except OSError as err:
        for folder in reversed(made):
            _remove_quietly(folder)
        raise InputError(f"cannot be written: {err.strerror}", field=field,
                         value=str(target)) from None
    try:
        yield StagedFolder(staging, target)
        # mkdtemp makes 0700; give the folder the mode a plain mkdir would.
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(staging, 0o777 & ~umask)
        if exists or not _rename_folder(staging, target):
            _move_into(staging, target)
            staging.rmdir()
    except OSError as err:
        shutil.rmtree(staging, ignore_errors=True)
        for folder in reversed(made):
            _remove_quietly(folder)
        if _is_inside(err.filename, staging) or _is_inside(err.filename, target):
            raise InputError(f"cannot be written: {err.strerror}", field=field,
                             value=str(target)) from None
        raise
    except BaseException:
        shutil.rmtree(staging, ignore_errors=True)
        for folder in reversed(made):
            _remove_quietly(folder)
        raise


def _rename_folder(staging: Path, target: Path) -> bool:
    """Rename ``staging`` to ``target``; False when ``target`` appeared meanwhile."""
    try:
        os.rename(staging, target)
    except (FileExistsError, IsADirectoryError, NotADirectoryError):
        return False
    except OSError as err:
        import errno

        if err.errno == errno.ENOTEMPTY:
            return False
        raise
    return True


def _remove_quietly(folder: Path) -> None:
    try:
        folder.rmdir()
    except OSError:
        pass
