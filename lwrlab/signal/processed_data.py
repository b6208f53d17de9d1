"""A processed measurement: the filtered states and identification rows of a log, block by block.

:class:`ProcessedData` holds the raw samples and the processing chosen for them
(:func:`lwrlab.signal.processing.process` builds it); it computes the filtered states
(:meth:`ProcessedData.state_blocks`, :class:`States`) and the filtered regressor rows
(:meth:`ProcessedData.row_blocks`, :class:`RowBlock`) a block of ``block_s`` seconds at a time.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from lwrlab.signal.filters import _padlen, _window, central_difference, lowpass_span
from lwrlab.signal.rest import at_rest
from lwrlab.signal.velocity import VelocityChoice
from lwrlab.signal.zero_phase import butterworth_sos, settling_samples, sosfiltfilt_window

REGRESSOR_SAMPLES = 4096
"""Samples whose regressor is built at a time within a block (the full regressor of a block's
samples before its base columns are taken would be several times the block's rows)."""
STATE_HALO = 32
"""Working samples computed beyond a block on each side for its differences and the logged velocity's
shift (at most :data:`lwrlab.signal.velocity.MAX_DELAY_SAMPLES` plus two centred differences)."""

Regressor = Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
"""``(q, q̇, q̈) -> W``: sample-major stacked regressor rows ``(N·N_J, P)``."""


@dataclass(frozen=True)
class States:
    """Filtered joint states and torques at consecutive working samples (one block of a log)."""

    start: int
    """Working sample of the first row."""
    t: np.ndarray
    """(n,) times (s)."""
    q: np.ndarray
    """(n, N_J) filtered positions (rad)."""
    dq: np.ndarray
    """(n, N_J) velocities (rad/s)."""
    ddq: np.ndarray
    """(n, N_J) accelerations (rad/s²)."""
    tau: np.ndarray
    """(n, N_J) filtered torques (N·m)."""


@dataclass(frozen=True)
class RowBlock:
    """The identification rows of one block of a log, and the joint states they were built at."""

    w: np.ndarray
    """(rows·N_J, P) filtered regressor rows, sample-major."""
    tau: np.ndarray
    """(rows·N_J,) filtered torques (N·m)."""
    q: np.ndarray
    """(rows, N_J) filtered positions at the rows (rad)."""
    dq: np.ndarray
    """(rows, N_J) velocities at the rows (rad/s)."""
    ddq: np.ndarray
    """(rows, N_J) accelerations at the rows (rad/s²)."""


@dataclass(frozen=True)
class ProcessedData:
    """A measurement filtered and differentiated, at the working rate, with the identification rows.

    The raw samples are kept; states and torques at the working samples (``t``) are computed in
    blocks on demand (:meth:`state_blocks`; the whole arrays ``t``, ``q``, … are their concatenation,
    computed once when first read). ``index`` are the samples kept as identification rows (trimmed
    and decimated). :meth:`row_blocks` builds the filtered regressor rows block by block.
    """

    raw_t: np.ndarray
    """(N_raw,) times (s) of the raw samples."""
    raw_q: np.ndarray
    """(N_raw, N_J) raw positions (rad)."""
    raw_tau: np.ndarray
    """(N_raw, N_J) raw torques (N·m)."""
    raw_dq: np.ndarray | None
    """(N_raw, N_J) logged velocities (rad/s) when they are used, else None."""
    step: int
    """Raw samples per working sample (the thinning to the working rate)."""
    index: np.ndarray
    """(M,) working samples kept as identification rows (trimmed, decimated)."""
    cutoff_hz: float | None
    """The rows' cut-off (Hz), of the low-pass on τ and W; None: no filter."""
    order: int
    """Butterworth order."""
    difference_accuracy: int
    """Order of the centred differences (2 or 4)."""
    working_rate_hz: float
    """Rate of ``t`` (Hz)."""
    rate_hz: float
    """Rate of the identification rows (Hz)."""
    velocity: VelocityChoice
    """Where the velocities come from, and why."""
    block_samples: int
    """Working samples per block of :meth:`state_blocks` and :meth:`row_blocks`."""
    state_cutoff_hz: float | None
    """The states' cut-off (Hz), of the low-pass on the positions (and logged velocities); None: no filter."""
    rest_speeds: np.ndarray | None = None
    """(N_J,) rad/s: speeds below which a joint stands (its velocity is set to zero, see
    :mod:`lwrlab.signal.rest`); None: every speed is kept."""

    @property
    def filtered(self) -> bool:
        """Whether the torques and the regressor columns are low-passed."""
        return self.cutoff_hz is not None

    @property
    def n_working(self) -> int:
        """Number of working samples."""
        return -(-self.raw_t.shape[0] // self.step)

    @property
    def source_index(self) -> np.ndarray:
        """(N,) index of each working sample in the raw measurement."""
        return np.arange(0, self.raw_t.shape[0], self.step)

    @property
    def row_times(self) -> np.ndarray:
        """(M,) times of the identification rows (s)."""
        return self.raw_t[self.raw_index]

    @property
    def raw_index(self) -> np.ndarray:
        """(M,) index of each identification row in the raw measurement."""
        return self.index * self.step

    @cached_property
    def _whole(self) -> States:
        blocks = list(self.state_blocks())
        return States(0, *(np.concatenate([getattr(b, name) for b in blocks]) for name in _STATE_NAMES))

    @property
    def t(self) -> np.ndarray:
        """(N,) times (s) of the working samples."""
        return self.raw_t[:: self.step]

    @property
    def q(self) -> np.ndarray:
        """(N, N_J) filtered positions (rad)."""
        return self._whole.q

    @property
    def dq(self) -> np.ndarray:
        """(N, N_J) velocities (rad/s)."""
        return self._whole.dq

    @property
    def ddq(self) -> np.ndarray:
        """(N, N_J) accelerations (rad/s²)."""
        return self._whole.ddq

    @property
    def tau(self) -> np.ndarray:
        """(N, N_J) filtered torques (N·m)."""
        return self._whole.tau

    def _filtered_span(self, x: np.ndarray, start: int, stop: int, cutoff_hz: float | None) -> np.ndarray:
        """Working samples ``[start, stop)`` of the raw signal ``x`` low-passed at ``cutoff_hz`` (None: not)
        and thinned."""
        raw_start, raw_stop = start * self.step, (stop - 1) * self.step + 1
        if cutoff_hz is None:
            return x[raw_start : raw_stop : self.step]
        rate = self.working_rate_hz * self.step
        return lowpass_span(x, raw_start, raw_stop, rate, cutoff_hz, self.order)[:: self.step]

    def states(self, start: int, stop: int, velocity: VelocityChoice | None = None) -> States:
        """States and torques at the working samples ``[start, stop)``, equal to the whole log's.

        ``velocity``: the velocity source (default: :attr:`velocity`).
        """
        choice = self.velocity if velocity is None else velocity
        lo, hi = max(0, start - STATE_HALO), min(self.n_working, stop + STATE_HALO)
        q = self._filtered_span(self.raw_q, lo, hi, self.state_cutoff_hz)
        dt = 1.0 / self.working_rate_hz
        velocities = central_difference(q, dt, self.difference_accuracy)
        if choice.logged and self.raw_dq is not None:
            velocities = choice.apply(self._filtered_span(self.raw_dq, lo, hi, self.state_cutoff_hz))
        accelerations = central_difference(velocities, dt, self.difference_accuracy)
        kept = slice(start - lo, stop - lo)
        return States(
            start,
            self.raw_t[start * self.step : (stop - 1) * self.step + 1 : self.step],
            q[kept],
            # after the accelerations: a standing joint's speed is zero, its acceleration not stepped
            at_rest(velocities[kept], self.rest_speeds),
            accelerations[kept],
            self._filtered_span(self.raw_tau, start, stop, self.cutoff_hz),
        )

    def state_blocks(self, start: int = 0, stop: int | None = None) -> Iterator[States]:
        """:meth:`states` over the working samples ``[start, stop)`` in blocks of ``block_samples``."""
        stop = self.n_working if stop is None else stop
        for first in range(start, stop, self.block_samples):
            yield self.states(first, min(stop, first + self.block_samples))

    def velocities(self, stop: int | None = None) -> np.ndarray:
        """(stop, N_J) velocities (rad/s) of the working samples ``[0, stop)``, built block by block
        (the whole states are not kept: a friction law's memory needs the velocities only)."""
        stop = self.n_working if stop is None else min(stop, self.n_working)
        out = np.empty((stop, self.raw_q.shape[1]))
        for block in self.state_blocks(0, stop):
            out[block.start : block.start + len(block.t)] = block.dq
        return out

    def row_blocks(self, regressor: Regressor) -> Iterator[RowBlock]:
        """The identification rows block by block (see :meth:`rows`), in the order of ``index``."""
        if self.index.size == 0:
            return
        n = self.n_working
        sos = (
            None
            if self.cutoff_hz is None
            else butterworth_sos(self.order, self.cutoff_hz, self.working_rate_hz)
        )
        overlap = 0 if sos is None else settling_samples(sos)
        padlen = 0 if self.cutoff_hz is None else _padlen(n, self.working_rate_hz, self.cutoff_hz)
        for start in range(int(self.index[0]), int(self.index[-1]) + 1, self.block_samples):
            stop = min(n, start + self.block_samples)
            rows = self.index[(self.index >= start) & (self.index < stop)]
            if rows.size == 0:
                continue
            # built in a call of its own: a block's regressor is freed before the next one is built
            yield self._row_block(regressor, rows, sos, _window(n, start, stop, overlap, padlen))

    def _row_block(
        self,
        regressor: Regressor,
        rows: np.ndarray,
        sos: np.ndarray | None,
        window: tuple[int, int, int, int],
    ) -> RowBlock:
        """The rows ``rows`` (working samples) of the block filtered from ``window`` (see :func:`_window`)."""
        lo, hi, before, after = window
        states = self.states(lo, hi)
        w, columns = _block_regressor(regressor, states)
        if sos is not None:
            w = sosfiltfilt_window(sos, w, before, after, overwrite_x=True)
        kept = rows - lo
        return RowBlock(
            w[kept].reshape(-1, columns),
            states.tau[kept].ravel(),
            states.q[kept],
            states.dq[kept],
            states.ddq[kept],
        )

    def rows(self, regressor: Regressor) -> tuple[np.ndarray, np.ndarray]:
        """The identification rows ``(W, τ)``: ``regressor`` at every working sample, filtered like τ.

        Parameters
        ----------
        regressor : ``(q, q̇, q̈) -> W``, sample-major stacked rows ``(N·N_J, P)``.

        Returns
        -------
        W : (M·N_J, P) filtered regressor rows; tau : (M·N_J,) filtered torques.
        """
        blocks = list(self.row_blocks(regressor))
        return np.vstack([b.w for b in blocks]), np.concatenate([b.tau for b in blocks])

    def describe(self) -> str:
        """One line saying what was chosen (cut-off, rates, velocity source)."""
        cutoff = (
            "no filter"
            if self.cutoff_hz is None
            else f"low-pass {self.cutoff_hz:.3g} Hz (order {self.order}) on τ and W, "
            f"q at {self.state_cutoff_hz:.3g} Hz for them"
        )
        return (
            f"{cutoff}; {len(self.index)} rows at {self.rate_hz:.4g} Hz "
            f"(working rate {self.working_rate_hz:.4g} Hz); "
            f"velocity: {self.velocity.describe()}"
        )


_STATE_NAMES = ("t", "q", "dq", "ddq", "tau")


def _block_regressor(regressor: Regressor, states: States) -> tuple[np.ndarray, int]:
    """``(W, P)``: the regressor at every sample of ``states`` as one row per sample (n, N_J·P),
    built :data:`REGRESSOR_SAMPLES` (or the regressor's ``chunk_samples``) at a time, column-major:
    the filter reads and writes its columns as contiguous runs (row-major, a few columns taken at a
    time cost it a third more)."""
    n, n_joints = states.q.shape
    chunk = int(getattr(regressor, "chunk_samples", REGRESSOR_SAMPLES))  # a wide regressor: fewer

    def part(first: int) -> np.ndarray:
        chosen = slice(first, first + chunk)
        if getattr(regressor, "takes_start", False):  # a friction law's memory: the samples' index
            rows = regressor(  # type: ignore[call-arg]
                states.q[chosen], states.dq[chosen], states.ddq[chosen], start=states.start + first
            )
        else:
            rows = regressor(states.q[chosen], states.dq[chosen], states.ddq[chosen])
        return rows.reshape(-1, n_joints * rows.shape[1])

    head = part(0)
    w = np.empty((n, head.shape[1]), order="F")
    w[: head.shape[0]] = head
    for first in range(chunk, n, chunk):
        w[first : first + chunk] = part(first)
    return w, head.shape[1] // n_joints
