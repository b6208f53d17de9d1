"""What the checks of a recorded log report: :class:`Finding` objects naming the file columns of
:class:`LogColumns`, and :func:`raise_for_errors`, which turns the errors into one
:class:`~lwrlab.io.log_schema.LogError` (:mod:`lwrlab.io.plausibility` checks the values,
:mod:`lwrlab.io.column_types` the column types).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass

from lwrlab.io.log_schema import LogError, joint_columns

SEVERITIES = ("error", "warning")


@dataclass(frozen=True)
class Finding:
    """One implausibility found in a log."""

    severity: str
    """``error`` (the log must not be fitted) or ``warning`` (fit, but say so)."""
    file: str
    """The log file."""
    column: str | None
    """The column of the file concerned (its name in the file), or None for the whole log."""
    check: str
    """Which check found it (the table of :mod:`lwrlab.io.plausibility`), e.g. ``torque_limit``."""
    message: str
    """What is wrong and what to do, in a sentence."""

    def __post_init__(self) -> None:
        if self.severity not in SEVERITIES:
            raise ValueError(f"severity must be one of {SEVERITIES}, got {self.severity!r}")

    def __str__(self) -> str:
        where = f"column {self.column!r}: " if self.column is not None else ""
        return f"{self.file}: {where}{self.message} [{self.check}]"


@dataclass(frozen=True)
class LogColumns:
    """The names, in the file, of the columns each quantity came from (for the messages)."""

    t: str
    """Time column."""
    q: tuple[str, ...]
    """Position column of each joint."""
    tau: tuple[str, ...]
    """Torque (or current) column of each joint."""
    dq: tuple[str, ...] | None = None
    """Velocity column of each joint, if the log has them."""
    torque_from_current: bool = False
    """Whether the torques are ``drive_gains·current`` (changes the hint of ``torque_limit``)."""

    @classmethod
    def schema(
        cls,
        n_joints: int,
        column_map: Mapping[str, str] | None = None,
        torque_from_current: bool = False,
        velocities: bool = False,
    ) -> LogColumns:
        """The columns of the :mod:`lwrlab.io.logs` schema, renamed by ``column_map`` like the loader does."""
        mapping = dict(column_map or {})

        def names(prefix: str) -> tuple[str, ...]:
            return tuple(mapping.get(c, c) for c in joint_columns(prefix, n_joints))

        return cls(
            t=mapping.get("t", "t"),
            q=names("q"),
            tau=names("current" if torque_from_current else "tau"),
            dq=names("dq") if velocities else None,
            torque_from_current=torque_from_current,
        )


def raise_for_errors(findings: Iterable[Finding]) -> list[Finding]:
    """Raise one :class:`LogError` listing every error (and, below, the warnings).

    Without errors, return the warnings.
    """
    findings = list(findings)
    errors = [f for f in findings if f.severity == "error"]
    warnings = [f for f in findings if f.severity != "error"]
    if errors:
        files = sorted({f.file for f in errors})
        lines = [f"implausible log {', '.join(files)}: {len(errors)} error(s)"]
        lines += [f"  - {f}" for f in errors]
        if warnings:
            lines += ["  warnings:", *(f"  - {f}" for f in warnings)]
        raise LogError("\n".join(lines))
    return warnings
