"""A tracking companion launched before Hydra composes the config, so that MLflow loads meanwhile.

The tracking callback only exists once Hydra has composed the config twice (about half a second
on two cores). ``lwrlab`` therefore launches the companion first thing when its command line may
be a single tracked run (:func:`may_log_a_single_run`), and the callback adopts it
(:func:`take`) instead of launching its own. When the command line misleads (a preset that
sweeps, a config whose tracking is off), the companion is discarded unconfigured: it has touched
no store, and only its imports were spent.
"""

from __future__ import annotations

import atexit
import logging
from collections.abc import Sequence

from lwrlab.tracking.companion.companion_link import CompanionLink

log = logging.getLogger(__name__)

_NO_SINGLE_RUN = ("tracking=none", "hydra.callbacks.mlflow.companion=false", "hydra.mode=MULTIRUN")
"""Overrides after which no companion logs the job."""

_launched: CompanionLink | None = None


def may_log_a_single_run(overrides: Sequence[str]) -> bool:
    """Whether a command line (without the program) may run one job logged by a companion.

    Not with a Hydra flag (``-m``, ``--cfg``, ``--help``, …) nor with an override that sweeps or
    turns tracking or the companion off. Presets that sweep are only known once composed.

    Examples
    --------
    >>> may_log_a_single_run(["task=identification", "plant=log"])
    True
    >>> may_log_a_single_run(["-m", "seed=1,2"]), may_log_a_single_run(["tracking=none"])
    (False, False)
    """
    return not any(item.startswith("-") or item.replace(" ", "") in _NO_SINGLE_RUN for item in overrides)


def launch() -> None:
    """Launch a companion for the tracking callback to adopt; it is discarded at exit if it is not."""
    global _launched
    if _launched is not None:
        return
    try:
        _launched = CompanionLink.launch()
    except (OSError, ValueError) as error:  # ValueError: no fd passing (Windows); the callback retries
        log.debug("no early tracking companion (%s: %s)", type(error).__name__, error)
        return
    atexit.register(discard)


def take() -> CompanionLink | None:
    """The companion launched early, now the caller's (None if there is none)."""
    global _launched
    link, _launched = _launched, None
    return link


def discard() -> None:
    """End the companion launched early if nobody took it."""
    link = take()
    if link is not None:
        link.discard()


__all__ = ["discard", "launch", "may_log_a_single_run", "take"]
