"""The byte test that spares uploads a regex over every binary artifact never misses a secret key."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from lwrlab.tracking.job_config.redaction import (
    SECRET_KEY_WORD,
    Redactor,
    _may_name_a_secret_key,
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
