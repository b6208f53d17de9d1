"""Secrets kept out of tracking stores: passwords in URIs and secret environment values are redacted.

A shared MLflow store is read by everyone on the team, so nothing that is logged (params, tags, the
run name, warnings, text artifacts such as ``.hydra/overrides.yaml`` or the job log) may carry the
password of a database or tracking-server URI, or the value of a secret environment variable.

Examples
--------
>>> redact_uri_passwords("postgresql://user:secret@db.example.org/mlflow")
'postgresql://user:***@db.example.org/mlflow'
>>> Redactor.from_texts(["http://me:hunter22@host:5000"], environ={}).redact("run at hunter22")
'run at ***'
>>> redact_secret_assignments("+db.auth_token=abc123 seed=1")
'+db.auth_token=*** seed=1'
>>> is_secret_key("aws.secret_access_key"), is_secret_key("robot.dof")
(True, False)

Keys name secrets when their last dotted component contains ``password``, ``passwd``, ``secret``,
``token``, ``api_key``/``apikey``, ``auth``, ``credential`` or ``private_key`` (any case; ``_``, ``.``
or ``-`` between the two words of ``api key`` and ``private key``). Their values are redacted wherever
they are logged: params, tags, the run name, the overrides tag and every uploaded config copy (as
``key=value`` overrides, ``key: value`` YAML/JSON lines, and as the literal value anywhere else).
The job's own output folder on the local disk keeps the config as typed.
"""

from __future__ import annotations

import os
import re
import shutil
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

REDACTED = "***"

# scheme://user:PASSWORD@host — the password is everything between the first ':' after the user
# name and the '@' that starts the host.
_URI_PASSWORD = re.compile(
    r"(?P<head>\b[a-zA-Z][a-zA-Z0-9+.\-]*://[^/\s:@'\"]*:)(?P<password>[^@\s/'\"]+)(?=@)"
)
# ?password=...&token=... in query strings and key=value command lines.
_QUERY_SECRET = re.compile(
    r"(?i)(?P<head>\b(?:password|passwd|pwd|token|secret|api_key|access_key)=)(?P<password>[^&\s'\"]+)"
)
# _QUERY_SECRET's words (lower case) and their '=', for a quick test on raw bytes.
_QUERY_SECRET_LITERALS = tuple(
    f"{word}=".encode() for word in ("password", "passwd", "pwd", "token", "secret", "api_key", "access_key")
)
# ASCII whitespace (which no URI password match holds) as one byte, for finding a match's stretch.
_WHITESPACE_TO_SPACE = bytes.maketrans(b"\t\n\r\x0b\x0c", b"     ")
# Environment variables whose values are secrets (MLFLOW_TRACKING_PASSWORD, AWS_SECRET_ACCESS_KEY, …).
SECRET_ENVIRONMENT_NAME = re.compile(
    r"(?i)(PASSWORD|PASSWD|SECRET|TOKEN|API_?KEY|ACCESS_KEY|PRIVATE_KEY|CREDENTIAL)"
)
# A config key names a secret when its last component contains one of these words (any case).
SECRET_KEY_WORD = re.compile(
    r"(?i)(password|passwd|secret|token|api[_.\-]?key|apikey|auth|credential|private[_.\-]?key)"
)
# The literal spellings of SECRET_KEY_WORD's words (lower case), for a quick test on raw bytes.
_SECRET_KEY_WORD_LITERALS = tuple(
    word.encode()
    for word in (
        "password",
        "passwd",
        "secret",
        "token",
        "apikey",
        "auth",
        "credential",
        *(f"{head}{separator}key" for head in ("api", "private") for separator in ("", "_", ".", "-")),
    )
)
# Non-ASCII letters that match ASCII ones under re.IGNORECASE (İ, ı, ſ, K), as UTF-8, with that letter.
_ASCII_CASE_FOLDINGS = tuple(
    (letter.encode(), ascii_letter.encode())
    for letter, ascii_letter in zip("\u0130\u0131\u017f\u212a", "iisk", strict=True)
)
# ``api.key`` and ``private.key`` span the last dot: the whole key's tail is checked for them.
_SECRET_KEY_TAIL = re.compile(r"(?i)(api|private)\.key[\w\-]*$")
# ``key=value`` as in Hydra overrides, command lines and query strings (prefixes + ++ ~ allowed).
_ASSIGNMENT = re.compile(
    r"(?P<head>(?<![\w.\-])[+~]{0,2}(?P<key>\w[\w.\-]*)=)"
    r"(?P<value>'[^']*'|\"[^\"]*\"|\$\{[^}\s]*\}|(?:[^\s'\"&,]|,(?![+~]{0,2}\w[\w.\-]*=))+)"
)
# ``key: value`` as in YAML and JSON (the key may be quoted; the value runs to the end of the line
# or of a flow collection item).
_MAPPING = re.compile(
    r"(?P<head>(?P<quote>[\"']?)(?P<key>\w[\w.\-]*)(?P=quote)\s*:[ \t]+)"
    r"(?P<value>'[^'\n]*'|\"[^\"\n]*\"|\$\{[^}\n]*\}|[^\n,}\]#]+)"
)
# Values that are no secret: empty, missing, already redacted, or an interpolation naming one.
_NOT_A_SECRET = re.compile(r"^(?:|null|None|~|\?\?\?|\*\*\*|\$\{[^}]*\}|\{\}|\[\])$")
# Shorter values (a flag, a digit) would redact ordinary text and protect nothing.
MIN_SECRET_LENGTH = 4
# The configs Hydra saves in a job folder: they name the job's stores and secret-valued keys.
JOB_CONFIG_FILES = (".hydra/overrides.yaml", ".hydra/config.yaml", ".hydra/hydra.yaml")
# Text artifacts larger than this are not scanned (measurement CSVs carry numbers, not URIs).
MAX_SCANNED_BYTES = 20_000_000


def is_secret_key(key: str) -> bool:
    """Whether a config key (``db.auth_token``, ``+aws.secret_access_key``, ``API-KEY``) names a secret."""
    key = key.strip().lstrip("+~").strip("\"'")
    return bool(SECRET_KEY_WORD.search(key.rsplit(".", 1)[-1]) or _SECRET_KEY_TAIL.search(key))


def _unquoted(value: str) -> str:
    value = value.strip()
    if len(value) >= 2 and value[0] == value[-1] and value[0] in "'\"":
        return value[1:-1]
    return value


def _secret_matches(text: str) -> Iterator[re.Match[str]]:
    for pattern in (_ASSIGNMENT, _MAPPING):
        for match in pattern.finditer(text):
            if is_secret_key(match.group("key")) and not _NOT_A_SECRET.match(_unquoted(match.group("value"))):
                yield match


def redact_secret_assignments(text: str) -> str:
    """Replace the value of every ``secret_key=value`` and ``secret_key: value`` in ``text`` by ``***``."""

    def replace(match: re.Match[str]) -> str:
        value = match.group("value")
        if not is_secret_key(match.group("key")) or _NOT_A_SECRET.match(_unquoted(value)):
            return match.group(0)
        stripped = value.rstrip()
        quote = (
            stripped[0]
            if stripped[:1] in ("'", '"') and len(stripped) >= 2 and stripped[-1] == stripped[0]
            else ""
        )
        return match.group("head") + quote + REDACTED + quote + value[len(stripped) :]

    text = _ASSIGNMENT.sub(replace, text)
    return _MAPPING.sub(replace, text)


def secret_values_in(text: str) -> set[str]:
    """The values that :func:`redact_secret_assignments` removes from ``text`` (sweeps split at commas)."""
    values: set[str] = set()
    for match in _secret_matches(text):
        value = _unquoted(match.group("value"))
        values.add(value)
        values |= {part.strip() for part in value.split(",") if part.strip()}
    return values


def redact_secret_params(params: Mapping[str, str]) -> dict[str, str]:
    """Params with the value of every secret key replaced by ``***`` (short values included)."""
    return {
        key: REDACTED if is_secret_key(key) and not _NOT_A_SECRET.match(str(value)) else value
        for key, value in params.items()
    }


def redact_uri_passwords(text: str) -> str:
    """Replace the password of every ``scheme://user:password@host`` and ``password=...`` in ``text``."""
    text = _URI_PASSWORD.sub(lambda m: m.group("head") + REDACTED, text)
    return _QUERY_SECRET.sub(lambda m: m.group("head") + REDACTED, text)


def passwords_in(text: str) -> set[str]:
    """The passwords that :func:`redact_uri_passwords` would remove from ``text``."""
    found = {m.group("password") for m in _URI_PASSWORD.finditer(text)}
    found |= {m.group("password") for m in _QUERY_SECRET.finditer(text)}
    return {value for value in found if value != REDACTED}


def secret_environment_values(environ: Mapping[str, str] | None = None) -> set[str]:
    """Values of environment variables whose names say they hold secrets, and URI passwords in any."""
    environ = os.environ if environ is None else environ
    values: set[str] = set()
    for name, value in environ.items():
        if SECRET_ENVIRONMENT_NAME.search(name) and len(value) >= MIN_SECRET_LENGTH:
            values.add(value)
        values |= passwords_in(value)
    return values


@dataclass(frozen=True)
class Redactor:
    """Removes a fixed set of secret strings, and any URI password, from text.

    Parameters
    ----------
    secrets
        Literal strings to replace by ``***`` wherever they appear (longest first).
    """

    secrets: frozenset[str] = frozenset()

    @classmethod
    def from_config(
        cls, params: Mapping[str, str], texts: Iterable[str] = (), environ: Mapping[str, str] | None = None
    ) -> Redactor:
        """Secrets of a job: values of its secret keys (flattened config), plus :meth:`from_texts`."""
        values = [str(value) for key, value in params.items() if is_secret_key(key)]
        found = cls.from_texts([*texts, *params.values()], environ)
        pieces = {piece.strip() for value in values for piece in [value, *value.split(",")]}
        extra = {
            piece for piece in pieces if len(piece) >= MIN_SECRET_LENGTH and not _NOT_A_SECRET.match(piece)
        }
        return cls(found.secrets | frozenset(extra))

    @classmethod
    def from_texts(cls, texts: Iterable[str], environ: Mapping[str, str] | None = None) -> Redactor:
        """Collect the passwords found in ``texts`` (config values, overrides, URIs) and the environment."""
        secrets = set(secret_environment_values(environ))
        for text in texts:
            secrets |= passwords_in(str(text)) | secret_values_in(str(text))
        return cls(frozenset(value for value in secrets if len(value) >= MIN_SECRET_LENGTH))

    @classmethod
    def for_output_folder(cls, output_dir: Path, environ: Mapping[str, str] | None = None) -> Redactor:
        """Secrets of the job that wrote ``output_dir``, read from its ``.hydra/`` configs and overrides."""
        texts = []
        for name in JOB_CONFIG_FILES:
            path = output_dir / name
            if path.is_file():
                texts.append(path.read_text(encoding="utf-8", errors="replace"))
        return cls.from_texts(texts, environ)

    def redact(self, text: str) -> str:
        """``text`` without URI passwords, secret-key values and any of the known secrets."""
        text = redact_secret_assignments(redact_uri_passwords(text))
        for secret in sorted(self.secrets, key=len, reverse=True):
            text = text.replace(secret, REDACTED)
        return text

    def needs_redaction(self, data: bytes) -> bool:
        """Whether ``data`` holds a known secret, a URI password or a secret-key assignment."""
        if any(secret.encode("utf-8") in data for secret in self.secrets):
            return True
        folded = _folded(data)
        if b"://" in data and (_uri_password_in(data) or _query_secret_in(data, folded)):
            return True
        if not _may_name_a_secret_key(data, folded):  # most artifacts (numbers, images): no regex
            return False  # over megabytes
        text = data.decode("utf-8", errors="replace")
        return redact_secret_assignments(text) != text

    def redact_mapping(self, values: Mapping[str, str]) -> dict[str, str]:
        """Redact every value (and key) of a params or tags mapping; secret keys lose their whole value."""
        values = redact_secret_params({str(key): str(value) for key, value in values.items()})
        return {self.redact(key): self.redact(value) for key, value in values.items()}


def _folded(data: bytes) -> bytes:
    """``data`` with ASCII letters lowered and the non-ASCII letters that Python's case-insensitive
    matching equates with ASCII ones replaced by them: a word the regexes match in any case is found
    in it by a byte search."""
    for letter, ascii_letter in _ASCII_CASE_FOLDINGS:
        if letter in data:  # rare: a search spares a copy of a large file
            data = data.replace(letter, ascii_letter)
    return data.lower()  # ASCII letters only


def _may_name_a_secret_key(data: bytes, folded: bytes | None = None) -> bool:
    """A necessary condition for a match of :data:`SECRET_KEY_WORD` in ``data`` decoded: one of its words
    in :func:`_folded` ``data`` (``folded``, when the caller has it already). Byte searches, far faster
    than the regex on a decoded binary file (a Parquet table, an image)."""
    folded = _folded(data) if folded is None else folded
    return any(word in folded for word in _SECRET_KEY_WORD_LITERALS)


def _uri_password_in(data: bytes) -> bool:
    """Whether :data:`_URI_PASSWORD` finds a password (not already redacted) in ``data`` decoded.

    A match holds ``://`` and no whitespace, so it lies within the stretch between ASCII whitespace
    around one ``://``; only those stretches are decoded and searched (ASCII bytes decode alone, so a
    stretch decodes as it does within the whole). A binary artifact holds ``://`` by chance (a 7 MB
    Parquet table of floats about every other time): the regex over all of it took most of a second.
    """
    spaced = data.translate(_WHITESPACE_TO_SPACE)
    searched = 0  # the stretches before are searched
    while (separator := spaced.find(b"://", searched)) >= 0:
        start = max(spaced.rfind(b" ", searched, separator) + 1, searched)
        end = spaced.find(b" ", separator)
        end = len(spaced) if end < 0 else end
        text = data[start:end].decode("utf-8", errors="replace")
        if any(match.group("password") != REDACTED for match in _URI_PASSWORD.finditer(text)):
            return True
        searched = end + 1
    return False


def _query_secret_in(data: bytes, folded: bytes) -> bool:
    """Whether :data:`_QUERY_SECRET` finds a value (not already redacted) in ``data`` decoded; the regex
    runs only where one of its words and its '=' are in ``folded`` (:func:`_folded` ``data``)."""
    if not any(word in folded for word in _QUERY_SECRET_LITERALS):
        return False
    text = data.decode("utf-8", errors="replace")
    return any(match.group("password") != REDACTED for match in _QUERY_SECRET.finditer(text))


def _files_needing_redaction(folder: Path, redactor: Redactor) -> Iterator[Path]:
    for path in folder.rglob("*"):
        scanned = path.is_file() and not path.is_symlink() and path.stat().st_size <= MAX_SCANNED_BYTES
        if scanned and redactor.needs_redaction(path.read_bytes()):
            yield path


@contextmanager
def redacted_folder(folder: Path, redactor: Redactor, exclude: Iterable[str] = ()) -> Iterator[Path]:
    """A folder to upload in place of ``folder``: the same files, with secrets redacted.

    Without secrets to remove (the usual case) it is ``folder`` itself, uncopied. Otherwise a
    temporary copy in which text files are redacted and binary files holding a secret are left out.

    Parameters
    ----------
    folder
        The job output folder.
    redactor
        What to remove.
    exclude
        File names (relative to ``folder``) never uploaded, e.g. the offline record of a run.
    """
    excluded = set(exclude)
    dirty = [
        path
        for path in _files_needing_redaction(folder, redactor)
        if str(path.relative_to(folder)) not in excluded
    ]
    if not dirty and not any((folder / name).exists() for name in excluded):
        yield folder
        return
    with tempfile.TemporaryDirectory(prefix="lwrlab_redacted_") as staging:
        copy = Path(staging) / folder.name
        shutil.copytree(folder, copy, symlinks=False, ignore_dangling_symlinks=True)
        for name in excluded:
            (copy / name).unlink(missing_ok=True)
        for path in dirty:
            target = copy / path.relative_to(folder)
            try:
                target.write_text(redactor.redact(path.read_bytes().decode("utf-8")), encoding="utf-8")
            except UnicodeDecodeError:  # a binary file holding a secret: better missing than leaking
                target.unlink()
        yield copy


__all__ = [
    "REDACTED",
    "Redactor",
    "is_secret_key",
    "passwords_in",
    "redact_secret_assignments",
    "redact_secret_params",
    "redact_uri_passwords",
    "redacted_folder",
    "secret_environment_values",
    "secret_values_in",
]
