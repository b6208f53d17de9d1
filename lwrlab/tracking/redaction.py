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
_URI_PASSWORD = re.compile(r"(?P<head>\b[a-zA-Z][a-zA-Z0-9+.\-]*://[^/\s:@'\"]*:)(?P<password>[^@\s/'\"]+)(?=@)")
# ?password=...&token=... in query strings and key=value command lines.
_QUERY_SECRET = re.compile(r"(?i)(?P<head>\b(?:password|passwd|pwd|token|secret|api_key|access_key)=)(?P<password>[^&\s'\"]+)")
# Environment variables whose values are secrets (MLFLOW_TRACKING_PASSWORD, AWS_SECRET_ACCESS_KEY, PGPASSWORD…).
SECRET_ENVIRONMENT_NAME = re.compile(r"(?i)(PASSWORD|PASSWD|SECRET|TOKEN|API_?KEY|ACCESS_KEY|PRIVATE_KEY|CREDENTIAL)")
# Shorter values (a flag, a digit) would redact ordinary text and protect nothing.
MIN_SECRET_LENGTH = 4
# Text artifacts larger than this are not scanned (measurement CSVs carry numbers, not URIs).
MAX_SCANNED_BYTES = 20_000_000


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
    def from_texts(cls, texts: Iterable[str], environ: Mapping[str, str] | None = None) -> Redactor:
        """Collect the passwords found in ``texts`` (config values, overrides, URIs) and the environment."""
        secrets = set(secret_environment_values(environ))
        for text in texts:
            secrets |= passwords_in(str(text))
        return cls(frozenset(value for value in secrets if len(value) >= MIN_SECRET_LENGTH))

    def redact(self, text: str) -> str:
        """``text`` without URI passwords and without any of the known secrets."""
        text = redact_uri_passwords(text)
        for secret in sorted(self.secrets, key=len, reverse=True):
            text = text.replace(secret, REDACTED)
        return text

    def needs_redaction(self, data: bytes) -> bool:
        """Whether ``data`` holds a known secret or a URI password."""
        if any(secret.encode("utf-8") in data for secret in self.secrets):
            return True
        return b"://" in data and bool(passwords_in(data.decode("utf-8", errors="replace")))

    def redact_mapping(self, values: Mapping[str, str]) -> dict[str, str]:
        """Redact every value (and key) of a params or tags mapping."""
        return {self.redact(str(key)): self.redact(str(value)) for key, value in values.items()}


def _files_needing_redaction(folder: Path, redactor: Redactor) -> Iterator[Path]:
    for path in folder.rglob("*"):
        if path.is_file() and not path.is_symlink() and path.stat().st_size <= MAX_SCANNED_BYTES:
            if redactor.needs_redaction(path.read_bytes()):
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
    dirty = [path for path in _files_needing_redaction(folder, redactor) if str(path.relative_to(folder)) not in excluded]
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
    "passwords_in",
    "redact_uri_passwords",
    "redacted_folder",
    "secret_environment_values",
]
