"""English descriptions of an assembly parsed into logical formulas (DESIGN.md §4 "Language").

The language is the paper's (§6): the nouns *wall*, *window* and *door*, each
with an optional article (*a*, *the*); the relations *left of*, *right of*,
*perpendicular to* and *coplanar to*; the conjunction *and*, between clauses
("a door and a window") and between relations that share their object
("window left of and perpendicular to door"); a clause may carry further
predicates of its subject ("door left of window and coplanar to wall"). Sentences
end with a full stop; several sentences (one string, or a list of strings) are
one description, the conjunction of all of them. Words are case-insensitive.
The grammar is ``grammar.lark`` beside this module (lark, LALR).

Coreference
-----------
**A noun names the same thing wherever it occurs in one description**: every
mention of *door* in "a door and a window. window left of door" is the same
door, every mention of *window* the same window, so that description has two
entities, a door and a window, and says the window is left of the door. Each
entity is existential (the solver chooses where it stands). The articles change
nothing ("a door", "the door" and "door" are one noun phrase), so "door
perpendicular to door" speaks of one door perpendicular to itself, which no
structure satisfies; the language cannot speak of two doors (it has no numerals
and no "another"), and a description constrains one door, one window and one
wall at most. A sentence therefore never introduces a second door to a reader
who has already met one, which is how a person describing one assembly uses
these words.

The formula of a description is a :class:`Conjunction` (one per sentence) of
:class:`Exists` (every noun phrase) and :class:`Relation` (every relation, its
subject the clause's subject, its object the noun phrase after it).

Examples
--------
>>> d = parse("a door and a window. Window left of and perpendicular to the door.")
>>> [e.kind for e in d.entities]
['door', 'window']
>>> [str(r) for r in d.relations]
['window left of door', 'window perpendicular to door']
>>> str(d)
'door and window. window left of and perpendicular to door.'
"""

from __future__ import annotations

import difflib
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from importlib.resources import files
from typing import Any

from unseeable.errors import InputError

__all__ = [
    "NOUNS", "RELATIONS", "RELATION_WORDS", "VOCABULARY", "Entity", "Exists", "Relation",
    "Conjunction", "Formula", "Description", "DescriptionError", "UnknownWordError",
    "UngrammaticalError", "UnsatisfiableError", "parse",
]

#: The nouns, in the order entities are listed when a description mentions several.
NOUNS = ("door", "window", "wall")
#: Relation names (the formula's) -> their English words.
RELATION_WORDS = {"left_of": "left of", "right_of": "right of",
                  "perpendicular_to": "perpendicular to", "coplanar_to": "coplanar to"}
#: The relation names.
RELATIONS = tuple(RELATION_WORDS)
#: Every word of the language.
VOCABULARY = ("a", "and", "coplanar", "door", "left", "of", "perpendicular", "right", "the",
              "to", "wall", "window")

# Wording of the parser's terminals in "expected ..." messages.
_EXPECTED_WORDS = {
    "NOUN": "a noun (door, window, wall)",
    "ARTICLE": "a noun (door, window, wall)",  # with or without its article
    "_AND": "'and'",
    "_LEFT": "a relation (left of, right of, perpendicular to, coplanar to)",
    "_RIGHT": "a relation (left of, right of, perpendicular to, coplanar to)",
    "_PERPENDICULAR": "a relation (left of, right of, perpendicular to, coplanar to)",
    "_COPLANAR": "a relation (left of, right of, perpendicular to, coplanar to)",
    "_OF": "'of'",
    "_TO": "'to'",
    "_PERIOD": "'.'",
    "$END": "the end of the description",
}
_WORD = re.compile(r"[A-Za-z]+|\.|\s+|.", re.S)


class DescriptionError(InputError):
    """A description that cannot be used; the message says what to change, in one line."""

    def __init__(self, message: str) -> None:
        super().__init__(message)


class UnknownWordError(DescriptionError):
    """A word outside the vocabulary (the message names the nearest word)."""


class UngrammaticalError(DescriptionError):
    """Words of the language in an order its grammar does not allow (the message gives the
    column and what was expected)."""


class UnsatisfiableError(DescriptionError):
    """No valid structure on the grid satisfies the description
    (:func:`~unseeable.language.check_satisfiable`)."""


@dataclass(frozen=True, order=True)
class Entity:
    """The thing a noun names in a description: one per noun (see the module docstring).

    Attributes
    ----------
    kind : {"door", "window", "wall"}
    """

    kind: str

    def __post_init__(self) -> None:
        if self.kind not in NOUNS:
            raise InputError(f"must be one of {', '.join(NOUNS)}", field="kind", value=self.kind)

    def __str__(self) -> str:
        return self.kind


@dataclass(frozen=True)
class Exists:
    """The entity stands somewhere in the structure."""

    entity: Entity

    def __str__(self) -> str:
        return str(self.entity)


@dataclass(frozen=True)
class Relation:
    """``subject`` stands in relation ``name`` to ``object``.

    Attributes
    ----------
    name : {"left_of", "right_of", "perpendicular_to", "coplanar_to"}
    subject, object : Entity
    """

    name: str
    subject: Entity
    object: Entity

    def __post_init__(self) -> None:
        if self.name not in RELATION_WORDS:
            raise InputError(f"must be one of {', '.join(RELATIONS)}", field="relation",
                             value=self.name)

    def __str__(self) -> str:
        return f"{self.subject} {RELATION_WORDS[self.name]} {self.object}"


@dataclass(frozen=True)
class Conjunction:
    """All of ``parts`` hold."""

    parts: tuple

    def __str__(self) -> str:
        return " and ".join(str(p) for p in self.parts)


Formula = Exists | Relation | Conjunction


def _atoms(formula: Formula) -> Iterable[Exists | Relation]:
    if isinstance(formula, Conjunction):
        for part in formula.parts:
            yield from _atoms(part)
    else:
        yield formula


def _unique(items: Iterable[Any]) -> tuple:
    return tuple(dict.fromkeys(items))


@dataclass(frozen=True)
class Description:
    """A parsed description: one formula per sentence, all of them conjoined.

    Attributes
    ----------
    sentences : tuple of Conjunction
        One per sentence, in order.
    text : str
        What was parsed (sentences given as a list are joined with spaces).
    """

    sentences: tuple
    text: str = ""

    @property
    def formula(self) -> Conjunction:
        """The whole description as one formula."""
        return Conjunction(tuple(self.sentences))

    @property
    def entities(self) -> tuple[Entity, ...]:
        """The entities, one per noun mentioned, in the order of :data:`NOUNS`."""
        kinds = {a.entity.kind if isinstance(a, Exists) else a.subject.kind
                 for a in _atoms(self.formula)}
        kinds |= {a.object.kind for a in _atoms(self.formula) if isinstance(a, Relation)}
        return tuple(Entity(k) for k in NOUNS if k in kinds)

    @property
    def relations(self) -> tuple[Relation, ...]:
        """The relations, each once, in the order they are first said."""
        return _unique(a for a in _atoms(self.formula) if isinstance(a, Relation))

    def sentence_texts(self) -> list[str]:
        """Each sentence in canonical words (articles dropped, relations of one subject and
        object joined by "and")."""
        return [_sentence_text(s) for s in self.sentences]

    def __str__(self) -> str:
        return " ".join(t + "." for t in self.sentence_texts())

    def __add__(self, other: Description) -> Description:
        if not isinstance(other, Description):
            return NotImplemented
        return Description(self.sentences + other.sentences,
                           " ".join(t for t in (self.text, other.text) if t))


def _sentence_text(sentence: Conjunction) -> str:
    """A sentence's formula in words: entities said alone, then each subject-object pair's
    relations joined ("window left of and perpendicular to door")."""
    atoms = list(_atoms(sentence))
    pairs: dict[tuple[Entity, Entity], list[str]] = {}
    for a in atoms:
        if isinstance(a, Relation):
            words = pairs.setdefault((a.subject, a.object), [])
            if RELATION_WORDS[a.name] not in words:
                words.append(RELATION_WORDS[a.name])
    related = {e for pair in pairs for e in pair}
    alone = _unique(a.entity for a in atoms if isinstance(a, Exists) and a.entity not in related)
    clauses = [str(e) for e in alone]
    clauses += [f"{s} {' and '.join(words)} {o}" for (s, o), words in pairs.items()]
    return " and ".join(clauses)


@lru_cache(maxsize=1)
def _parser():
    from lark import Lark

    grammar = files("unseeable.language").joinpath("grammar.lark").read_text(encoding="utf-8")
    return Lark(grammar, start="text", parser="lalr", propagate_positions=True)


def _check_words(text: str, where: str) -> None:
    """Raise :class:`UnknownWordError` at the first word (or character) outside the
    vocabulary."""
    for match in _WORD.finditer(text):
        token = match.group()
        column = match.start() + 1
        if token.isspace() or token == ".":
            continue
        if token.isalpha():
            if token.lower() in VOCABULARY:
                continue
            near = difflib.get_close_matches(token.lower(), VOCABULARY, n=1, cutoff=0.6)
            hint = (f"; did you mean {near[0]!r}?" if near
                    else f"; the words are: {', '.join(VOCABULARY)}")
            raise UnknownWordError(f"unknown word {token!r} at column {column}{where}{hint}")
        raise UnknownWordError(f"unexpected character {token!r} at column {column}{where}; "
                               "a description has words, spaces and full stops")


def _expected(names: Iterable[str]) -> str:
    words = _unique(_EXPECTED_WORDS.get(n, n) for n in sorted(names))
    return " or ".join(words)


def _syntax_error(err, text: str, where: str) -> UngrammaticalError:
    from lark.exceptions import UnexpectedEOF, UnexpectedToken

    expected = _expected(getattr(err, "expected", ()) or ())
    if isinstance(err, UnexpectedToken) and err.token.type != "$END":
        return UngrammaticalError(f"unexpected {str(err.token)!r} at column {err.column}{where}; "
                                  f"expected {expected}")
    if isinstance(err, (UnexpectedToken, UnexpectedEOF)):
        column = len(text.rstrip()) + 1
        return UngrammaticalError(f"the description ends too early at column {column}{where}; "
                                  f"expected {expected}")
    return UngrammaticalError(f"cannot read the description{where}: {err}")  # pragma: no cover


def _entity(noun_phrase) -> Entity:
    # noun_phrase: ARTICLE? NOUN; the article changes nothing (module docstring).
    return Entity(str(noun_phrase.children[-1]).lower())


def _clause(tree, out: list) -> None:
    """Atoms of a ``clause`` tree (and the clauses joined to it) appended to ``out``."""
    subject = _entity(tree.children[0])
    out.append(Exists(subject))
    tail = tree.children[1] if len(tree.children) > 1 else None
    while tail is not None:
        if tail.data == "more":
            _clause(tail.children[0], out)
            return
        relations, noun_phrase = tail.children[0], tail.children[1]
        obj = _entity(noun_phrase)
        out.append(Exists(obj))
        for relation in relations.children:
            out.append(Relation(str(relation.data), subject, obj))
        tail = tail.children[2] if len(tail.children) > 2 else None


def _parse_one(text: str, where: str) -> list[Conjunction]:
    from lark.exceptions import UnexpectedInput

    _check_words(text, where)
    if not text.strip(" \t\r\n."):
        raise UngrammaticalError(f"the description{where} is empty; say e.g. "
                                 "'window left of and perpendicular to door'")
    try:
        tree = _parser().parse(text)
    except UnexpectedInput as err:
        raise _syntax_error(err, text, where) from None
    sentences = []
    for sentence in tree.children:
        atoms: list = []
        _clause(sentence.children[0], atoms)
        sentences.append(Conjunction(_unique(atoms)))
    return sentences


def parse(text: str | Sequence[str] | Description) -> Description:
    """Parse an English description into a :class:`Description`.

    Parameters
    ----------
    text : str or sequence of str
        Sentences separated by full stops (the last one optional), or a list of
        them (each may hold several sentences). A :class:`Description` is
        returned as it is.

    Returns
    -------
    Description

    Raises
    ------
    UnknownWordError
        A word outside the vocabulary, with its column and the nearest word.
    UngrammaticalError
        The words in an order the grammar does not allow, with the column and what
        was expected there; or nothing to parse.

    Examples
    --------
    >>> str(parse(["the window left of the door", "door coplanar to wall"]))
    'window left of door. door coplanar to wall.'
    >>> try:
    ...     parse("window left of dore")
    ... except UnknownWordError as err:
    ...     print(err)
    unknown word 'dore' at column 16; did you mean 'door'?
    """
    if isinstance(text, Description):
        return text
    if isinstance(text, str):
        return Description(tuple(_parse_one(text, "")), text.strip())
    if not isinstance(text, Sequence) or not all(isinstance(t, str) for t in text):
        raise InputError("must be a string or a list of strings", field="description",
                         value=text)
    items = list(text)
    if not items:
        raise UngrammaticalError("the description is empty; say e.g. "
                                 "'window left of and perpendicular to door'")
    sentences = []
    for n, item in enumerate(items):
        where = f" of sentence {n + 1}" if len(items) > 1 else ""
        sentences += _parse_one(item, where)
    return Description(tuple(sentences), " ".join(t.strip() for t in items))
