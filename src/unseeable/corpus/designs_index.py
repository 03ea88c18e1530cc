"""Read the shipped corpus designs (``unseeable/data/corpus``): index and structures."""

from __future__ import annotations

import difflib
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

from unseeable.domain import GridPose, Structure, load_structure
from unseeable.errors import InputError
from unseeable.fileio import check_format, read_json, require

__all__ = ["CorpusEntry", "list_designs", "load_design", "design_names", "read_index"]

#: Where the shipped JSON files live (package data); same folder as ``designs.DATA_DIR``.
DATA_DIR = Path(__file__).resolve().parent.parent / "data" / "corpus"
INDEX_FORMAT = "unseeable/corpus-index@1"


@dataclass(frozen=True)
class CorpusEntry:
    """One designed structure of the corpus, placed on the table.

    Attributes
    ----------
    name : str
    structure : Structure
    pose : GridPose
        Where the structure stands on the table (structures related by a
        subset relation share it).
    description : str
        One line for people.
    subset_of : tuple of str
        Names of the corpus structures that strictly contain this one (same
        placement): the arm can turn any of them into this one.
    contains : tuple of str
        Names of the corpus structures this one strictly contains.
    file : Path
        The structure file.
    """

    name: str
    structure: Structure
    pose: GridPose
    description: str
    subset_of: tuple[str, ...] = ()
    contains: tuple[str, ...] = ()
    file: Path | None = None


def _str_list(value: object, *, file: Path, field: str) -> tuple[str, ...]:
    if not isinstance(value, list) or not all(isinstance(v, str) for v in value):
        raise InputError("must be a list of names", file=file, field=field, value=value)
    return tuple(value)


def pose_from_json(data: object, *, file: object = None, field: str = "pose") -> GridPose:
    """A :class:`GridPose` from ``{"x", "z", "yaw_deg"}``, with clear errors."""
    if not isinstance(data, dict):
        raise InputError("must be an object {x, z, yaw_deg}", file=file, field=field, value=data)
    values = [require(data, key, file=file, prefix=f"{field}.") for key in ("x", "z", "yaw_deg")]
    try:
        return GridPose(*values)
    except InputError as err:
        raise InputError(err.message, file=file, field=err.field, value=err.value) from None


def read_index(folder: str | Path = DATA_DIR) -> list[CorpusEntry]:
    """Load and validate a corpus index and every structure it names.

    Raises
    ------
    InputError
        Naming the file and field: a wrong format tag, a missing field, a
        duplicate name, a relation naming no design, an invalid structure.
    """
    folder = Path(folder)
    path = folder / "index.json"
    data = read_json(path)
    check_format(data, INDEX_FORMAT, file=path)
    items = require(data, "designs", file=path)
    if not isinstance(items, list):
        raise InputError("must be a list", file=path, field="designs", value=type(items).__name__)
    entries = []
    for n, item in enumerate(items):
        where = f"designs[{n}]"
        name = require(item, "name", file=path, prefix=f"{where}.")
        if not isinstance(name, str) or not name:
            raise InputError("must be a non-empty string", file=path, field=f"{where}.name",
                             value=name)
        file_name = require(item, "file", file=path, prefix=f"{where}.")
        if not isinstance(file_name, str) or Path(file_name).name != file_name:
            raise InputError("must be a file name in the index's folder", file=path,
                             field=f"{where}.file", value=file_name)
        description = require(item, "description", file=path, prefix=f"{where}.")
        if not isinstance(description, str):
            raise InputError("must be a string", file=path, field=f"{where}.description",
                             value=description)
        entries.append(CorpusEntry(
            name=name,
            structure=load_structure(folder / file_name),
            pose=pose_from_json(require(item, "pose", file=path, prefix=f"{where}."), file=path,
                                field=f"{where}.pose"),
            description=description,
            subset_of=_str_list(item.get("subset_of", []), file=path,
                                field=f"{where}.subset_of"),
            contains=_str_list(item.get("contains", []), file=path, field=f"{where}.contains"),
            file=folder / file_name,
        ))
    names = [e.name for e in entries]
    for n, e in enumerate(entries):
        if names.index(e.name) != n:
            raise InputError("names the same design twice", file=path, field=f"designs[{n}].name",
                             value=e.name)
        for key in ("subset_of", "contains"):
            for other in getattr(e, key):
                if other not in names:
                    raise InputError("names no design of the index", file=path,
                                     field=f"designs[{n}].{key}", value=other)
    return entries


@lru_cache(maxsize=1)
def _shipped() -> tuple[CorpusEntry, ...]:
    return tuple(read_index(DATA_DIR))


def list_designs() -> list[CorpusEntry]:
    """The 32 designed structures shipped with the package, in corpus order.

    Examples
    --------
    >>> entries = list_designs()
    >>> len(entries), entries[0].name
    (32, 'cabin-4x4')
    """
    return list(_shipped())


def design_names() -> list[str]:
    """Names of the shipped designs, in corpus order."""
    return [e.name for e in _shipped()]


def load_design(name: str) -> CorpusEntry:
    """The shipped design called ``name``.

    Raises
    ------
    InputError
        When there is no such design (the message suggests close names).

    Examples
    --------
    >>> load_design("cabin-door").structure.extent.shape
    (5, 6, 4)
    """
    for entry in _shipped():
        if entry.name == name:
            return entry
    close = difflib.get_close_matches(str(name), design_names(), n=3)
    hint = f"; did you mean {', '.join(close)}?" if close else \
        f"; the designs are {', '.join(design_names())}"
    raise InputError(f"no such corpus design{hint}", field="name", value=name)
