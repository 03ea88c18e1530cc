"""JSON file helpers shared by every file format: clear errors, atomic writes."""

from __future__ import annotations

import json
import os
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from unseeable.errors import InputError

__all__ = ["read_json", "write_json", "check_format", "atomic_write_bytes", "require"]


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
