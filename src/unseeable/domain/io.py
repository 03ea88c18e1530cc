"""The structure file format ``unseeable/structure@1`` (DESIGN.md §6)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from unseeable.domain.grid import Extent
from unseeable.domain.structure import Log, Structure, grammar_violations
from unseeable.errors import InputError
from unseeable.fileio import check_format, read_json, require, write_json

__all__ = ["STRUCTURE_FORMAT", "structure_to_json", "structure_from_json", "load_structure",
           "save_structure"]

STRUCTURE_FORMAT = "unseeable/structure@1"


def structure_to_json(structure: Structure) -> dict[str, Any]:
    """The structure as a JSON-ready dict.

    Examples
    --------
    >>> s = Structure(Extent(2, 1, 1), [Log(layer=0, at=(0, 0), notches=2)])
    >>> structure_to_json(s)["logs"]
    [{'notches': 2, 'layer': 0, 'at': [0, 0]}]
    """
    return {
        "format": STRUCTURE_FORMAT,
        "extent": structure.extent.as_list(),
        "logs": [{"notches": log.notches, "layer": log.layer, "at": list(log.at)}
                 for log in structure.logs],
    }


def _int_field(value: Any, *, file: Any, field: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise InputError("must be a whole number", file=file, field=field, value=value)
    return value


def structure_from_json(data: Any, *, file: Any = None, field: str = "",
                        check_grammar: bool = True) -> Structure:
    """Validate parsed JSON and build the :class:`Structure`.

    Raises
    ------
    InputError
        Naming the file, the field (e.g. ``logs[3]``) and the value: a wrong
        format tag, a log off the grid, overlapping logs, an unsupported log
        (grammar constraints (c)–(d)), a bad notch count.
    """
    prefix = f"{field}." if field else ""
    check_format(data, STRUCTURE_FORMAT, file=file, field=f"{prefix}format")
    extent = Extent.parse(require(data, "extent", file=file, prefix=prefix), file=file,
                          field=f"{prefix}extent")
    raw_logs = require(data, "logs", file=file, prefix=prefix)
    if not isinstance(raw_logs, list):
        raise InputError("must be a list of logs", file=file, field=f"{prefix}logs",
                         value=raw_logs)
    logs = []
    for n, item in enumerate(raw_logs):
        where = f"{prefix}logs[{n}]"
        if not isinstance(item, dict):
            raise InputError("must be an object {notches, layer, at}", file=file, field=where,
                             value=item)
        notches = _int_field(require(item, "notches", file=file, prefix=f"{where}."), file=file,
                             field=f"{where}.notches")
        if notches not in (1, 2, 3):
            raise InputError("a log has 1, 2 or 3 notches", file=file, field=f"{where}.notches",
                             value=notches)
        layer = _int_field(require(item, "layer", file=file, prefix=f"{where}."), file=file,
                           field=f"{where}.layer")
        at = require(item, "at", file=file, prefix=f"{where}.")
        if not (isinstance(at, list) and len(at) == 2):
            raise InputError("must be [i, k]", file=file, field=f"{where}.at", value=at)
        at = tuple(_int_field(a, file=file, field=f"{where}.at") for a in at)
        logs.append(Log(layer=layer, at=at, notches=notches))
    # Structure sorts its logs; validate in file order so messages name the file's index.
    for n in range(len(logs)):
        try:
            Structure(extent, logs[: n + 1])
        except InputError as err:
            raise InputError(err.message, file=file, field=f"{prefix}logs[{n}]",
                             value=err.value) from None
    structure = Structure(extent, logs)
    if check_grammar:
        problems = grammar_violations(structure)
        if problems:
            # Report the offending log by its index in the file.
            bad = structure.logs[int(problems[0].split("]")[0].split("[")[1])]
            n = logs.index(bad)
            reason = problems[0].split(": ", 1)[1]
            raise InputError(f"violates the grammar: {reason}", file=file,
                             field=f"{prefix}logs[{n}]", value=bad.describe())
    return structure


def load_structure(path: str | Path, *, check_grammar: bool = True) -> Structure:
    """Load and validate a structure file."""
    return structure_from_json(read_json(path), file=path, check_grammar=check_grammar)


def save_structure(structure: Structure, path: str | Path) -> None:
    write_json(path, structure_to_json(structure))
