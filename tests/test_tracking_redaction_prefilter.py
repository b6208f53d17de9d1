"""The byte test that spares uploads a regex over every binary artifact never misses a secret key."""

from __future__ import annotations

import re
from collections.abc import Iterator
from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from lwrlab.tracking.job_config import redaction
from lwrlab.tracking.job_config.redaction import (
    _URI_PASSWORD,
    REDACTED,
    SECRET_KEY_WORD,
    Redactor,
    _may_name_a_secret_key,
    _uri_password_in,
    passwords_in,
    redact_secret_assignments,
)

WORDS = (
    "password",
    "passwd",
    "secret",
    "token",
    "api_key",
    "api.key",
    "apikey",
    "auth",
    "credential",
    "private-key",
)
# Characters that case-insensitive matching equates with ASCII letters of the words, and others.
SPELLINGS = {"i": ["i", "I", "\u0130", "\u0131"], "s": ["s", "S", "\u017f"], "k": ["k", "K", "\u212a"]}


@st.composite
def spelled_word(draw: st.DrawFn) -> str:
    """A secret word in any case, possibly with the non-ASCII letters that match ASCII ones."""
    word = draw(st.sampled_from(WORDS))
    return "".join(draw(st.sampled_from(SPELLINGS.get(letter, [letter, letter.upper()]))) for letter in word)


@given(prefix=st.binary(max_size=40), word=spelled_word(), suffix=st.binary(max_size=40))
def test_a_secret_word_anywhere_passes_the_byte_test(prefix: bytes, word: str, suffix: bytes) -> None:
    data = prefix + b" db." + word.encode() + b"=abcdef12\n" + suffix
    assert _may_name_a_secret_key(data)
    text = data.decode("utf-8", errors="replace")
    if SECRET_KEY_WORD.search(text) and redact_secret_assignments(text) != text:
        assert Redactor.from_config({}, environ={}).needs_redaction(data)


@given(data=st.binary(max_size=300) | st.text(max_size=300).map(str.encode))
def test_the_byte_test_is_a_necessary_condition(data: bytes) -> None:
    text = data.decode("utf-8", errors="replace")
    if SECRET_KEY_WORD.search(text):
        assert _may_name_a_secret_key(data)
    # The same answer as the scan without the byte test (no known secrets here).
    without_byte_test = (b"://" in data and bool(passwords_in(text))) or redact_secret_assignments(
        text
    ) != text
    assert Redactor.from_config({}, environ={}).needs_redaction(data) == without_byte_test


def test_numbers_and_images_skip_the_regex() -> None:
    assert not _may_name_a_secret_key(b"t,tau1,tau2\n0.001,1.5,-2.25\n" * 1000 + bytes(range(256)))


# Pieces of URIs and query strings, with the separators and look-alike letters that decide a match.
URI_PIECES = st.sampled_from(
    [
        b"://",
        b"postgresql://",
        b"http://me:",
        b"me:",
        b"hunter22",
        b"***",
        b"@host",
        b"@",
        b"/",
        b":",
        b" ",
        b"\n",
        b"\t",
        b"\x0b",
        b"'",
        b"\xc4",
        b"\xb0",
        "\u2028".encode(),
        "\u0131".encode(),
        b"pwd=",
        b"PWD=x",
        "\u017f".encode() + b"ecret=",
        b"&token=",
        b"a",
        b"=",
        b"\x00",
    ]
)


@given(pieces=st.lists(URI_PIECES | st.binary(max_size=6), max_size=24))
def test_uri_passwords_found_as_a_search_of_the_whole_text_finds_them(pieces: list[bytes]) -> None:
    data = b"".join(pieces)
    text = data.decode("utf-8", errors="replace")
    expected = any(match.group("password") != REDACTED for match in _URI_PASSWORD.finditer(text))
    assert _uri_password_in(data) == expected
    without_byte_test = (b"://" in data and bool(passwords_in(text))) or redact_secret_assignments(
        text
    ) != text
    assert Redactor.from_config({}, environ={}).needs_redaction(data) == without_byte_test


class RecordingPattern:
    """A compiled regex that records the length of every text it searches."""

    def __init__(self, pattern: re.Pattern[str]) -> None:
        self.pattern, self.lengths = pattern, []

    def finditer(self, text: str) -> Iterator[re.Match[str]]:
        self.lengths.append(len(text))
        return self.pattern.finditer(text)


def test_a_uri_separator_by_chance_in_a_binary_is_searched_around_it_only(monkeypatch: Any) -> None:
    uri, query = RecordingPattern(redaction._URI_PASSWORD), RecordingPattern(redaction._QUERY_SECRET)
    monkeypatch.setattr(redaction, "_URI_PASSWORD", uri)
    monkeypatch.setattr(redaction, "_QUERY_SECRET", query)
    data = bytes(range(256)) * 4000 + b"://" + bytes(range(256)) * 4000  # 2 MB, no password
    assert not Redactor.from_config({}, environ={}).needs_redaction(data)
    assert uri.lengths and max(uri.lengths) < 300 and not query.lengths  # not the 2 MB
    assert not _uri_password_in(data + b" db://me:hunter22 @host")  # a space ends a password
    assert _uri_password_in(data + b" db://me:hunter22@host")
