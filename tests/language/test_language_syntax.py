"""Parsing descriptions: every construct, coreference, and errors a person can act on."""

from __future__ import annotations

import pytest

from unseeable.errors import InputError
from unseeable.language import (
    Conjunction,
    DescriptionError,
    Entity,
    Exists,
    Relation,
    UngrammaticalError,
    UnknownWordError,
    parse,
)

DOOR, WINDOW, WALL = Entity("door"), Entity("window"), Entity("wall")


def relations(text):
    return [(r.name, r.subject.kind, r.object.kind) for r in parse(text).relations]


@pytest.mark.parametrize("text", ["door", "a door", "the door", "A Door", "THE DOOR."])
def test_a_noun_with_or_without_its_article_is_one_entity_that_exists(text):
    d = parse(text)
    assert d.entities == (DOOR,)
    assert d.sentences == (Conjunction((Exists(DOOR),)),)


@pytest.mark.parametrize("words, name", [("left of", "left_of"), ("right of", "right_of"),
                                         ("perpendicular to", "perpendicular_to"),
                                         ("coplanar to", "coplanar_to")])
def test_each_relation(words, name):
    assert relations(f"window {words} door") == [(name, "window", "door")]


def test_and_between_relations_shares_the_object():
    assert relations("window left of and perpendicular to door") == [
        ("left_of", "window", "door"), ("perpendicular_to", "window", "door")]


def test_and_between_clauses():
    d = parse("a door and a window and a wall")
    assert d.entities == (DOOR, WINDOW, WALL) and d.relations == ()


def test_and_after_an_object_continues_the_subject_or_starts_a_clause():
    assert relations("door left of window and coplanar to wall") == [
        ("left_of", "door", "window"), ("coplanar_to", "door", "wall")]
    assert relations("door left of window and wall right of door") == [
        ("left_of", "door", "window"), ("right_of", "wall", "door")]


def test_sentences_are_conjoined_from_a_string_or_a_list():
    text = parse("a door and a window. window left of door.")
    listed = parse(["a door and a window", "window left of door"])
    assert text.sentences == listed.sentences
    assert len(text.sentences) == 2
    assert str(text) == "door and window. window left of door."


def test_the_same_noun_in_one_description_is_the_same_entity():
    d = parse("a door and a window. window left of door. the door coplanar to a wall")
    assert d.entities == (DOOR, WINDOW, WALL)  # one door, though said three times
    left, coplanar = d.relations
    assert left.object == coplanar.subject == DOOR


def test_a_noun_related_to_itself_is_one_entity():
    (r,) = parse("door perpendicular to door").relations
    assert r.subject == r.object == DOOR


def test_the_formula_is_small_frozen_data():
    d = parse("window right of door")
    assert d.formula == Conjunction((Conjunction((Exists(WINDOW), Exists(DOOR),
                                                  Relation("right_of", WINDOW, DOOR))),))
    with pytest.raises(AttributeError):
        d.sentences = ()  # frozen
    assert parse(d) is d


def test_canonical_text_parses_back_to_the_same_description():
    d = parse("A window left of and perpendicular to the door. door and wall")
    assert parse(str(d)).sentences == d.sentences


def _one_line(err: Exception) -> str:
    text = str(err)
    assert "\n" not in text
    return text


def test_an_unknown_word_is_named_with_its_column_and_the_nearest_word():
    with pytest.raises(UnknownWordError) as info:
        parse("window left of dore")
    assert _one_line(info.value) == "unknown word 'dore' at column 16; did you mean 'door'?"


def test_an_unknown_word_without_a_near_one_lists_the_vocabulary():
    with pytest.raises(UnknownWordError) as info:
        parse("window is left of door")
    text = _one_line(info.value)
    assert "'is' at column 8" in text and "the words are: a, and, coplanar" in text


def test_unknown_words_in_a_list_name_their_sentence():
    with pytest.raises(UnknownWordError, match="column 6 of sentence 2; did you mean 'left'"):
        parse(["door", "wall lefft of door"])


def test_a_character_outside_the_language_is_named():
    with pytest.raises(UnknownWordError, match=r"unexpected character ',' at column 5"):
        parse("door, window")


def test_an_ungrammatical_description_gives_the_column_and_what_was_expected():
    with pytest.raises(UngrammaticalError) as info:
        parse("window left door")
    assert _one_line(info.value) == "unexpected 'door' at column 13; expected 'of'"
    with pytest.raises(UngrammaticalError, match="'left' at column 1; expected a noun"):
        parse("left of door")


def test_a_description_that_ends_too_early_says_where_and_what_is_missing():
    with pytest.raises(UngrammaticalError) as info:
        parse("window perpendicular to")
    text = _one_line(info.value)
    assert text.startswith("the description ends too early at column 24; expected a noun")


@pytest.mark.parametrize("text", ["", "  . ", []])
def test_an_empty_description_is_an_error(text):
    with pytest.raises(UngrammaticalError, match="empty"):
        parse(text)


def test_description_errors_are_input_errors():
    assert issubclass(DescriptionError, InputError)
    with pytest.raises(InputError):
        parse(42)
