"""From raw samples (t, q, [q̇], τ) to the rows of the identification model ``W·φ = τ``.

The processing of the identification literature (Gautier's *parallel filtering and decimation*;
the paper's §III.E):

1. a zero-phase Butterworth low-pass on the positions (and on logged velocities): the states the
   regressor is evaluated at; velocities and accelerations by centred differences of the filtered
   signals;
2. the **same** low-pass on the torques and on every column of the regressor ``W`` — so that the
   filtered τ and the filtered W obey the same model, also for terms that are not smooth in time
   (Coulomb friction's sign(q̇) step is smeared alike on both sides);
3. decimation to ``rate_hz`` (the filter is the anti-aliasing filter), after trimming the filter's
   edge transients.

The cut-off defaults to ten times the motion's frequency (``cutoff_hz: auto``, Gautier's rule of a
filter ten times faster than the dynamics), measured on the positions of each log; the decimated
rate to five times the cut-off, whatever the log's rate. At high log rates the filtered signals are
first thinned to a working rate of 50 × the cut-off (the filter already removed everything above it),
so a long 1 kHz log does not build a 1 kHz regressor.

Long logs are processed in blocks of ``block_s`` seconds (:meth:`ProcessedData.row_blocks`,
:meth:`ProcessedData.state_blocks`): each block is filtered from a window that reaches
:func:`lwrlab.signal.zero_phase.settling_samples` beyond it on both sides, so it equals the
whole-signal filter to rounding (the start transient of a window has decayed below 1e-13), and
memory no longer grows with the log's length. A log shorter than a block is one block.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from lwrlab.errors import ConfigError
from lwrlab.signal.velocity import VelocityChoice, choose_velocity
from lwrlab.signal.zero_phase import butterworth_sos, settling_samples, sosfiltfilt_window

CUTOFF_PER_MOTION_FREQUENCY = 15.0
"""Auto cut-off = this × the motion's frequency (Gautier: a filter at least ten times faster than the
dynamics; 15 chosen by the processing study, benchmarks/processing_study.py)."""
MIN_AUTO_CUTOFF_HZ = 0.5
"""Lowest automatic cut-off (Hz)."""
DECIMATED_RATE_PER_CUTOFF = 5.0
"""Default decimated rate = this × the cut-off: Nyquist at 2.5 × the cut-off, where a 5th-order
Butterworth leaves 1e-4 of the signal."""
WORKING_RATE_PER_CUTOFF = 50.0
"""Filtered signals are thinned to at least this × the cut-off before building the regressor."""
TRIM_PER_CUTOFF_PERIOD = 2.0
"""Auto trimming at each end = this / cut-off seconds: a few time constants of the filter."""
VELOCITY_SOURCES = ("auto", "logged", "differentiated")
DEFAULT_BLOCK_S = 60.0
"""Seconds of log processed at a time (the regressor of a block at the working rate, filtered)."""
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


def _window(n: int, start: int, stop: int, overlap: int, padlen: int) -> tuple[int, int, int, int]:
    """``(lo, hi, pad_before, pad_after)``: the window of a signal of ``n`` samples that filters
    ``[start, stop)`` like the whole signal (``overlap`` samples beyond it, the odd extension of
    ``padlen`` samples only at the signal's own ends, which the window then must exceed)."""
    lo, hi = max(0, start - overlap), min(n, stop + overlap)
    if lo == 0:
        hi = max(hi, min(n, padlen + 1))
    if hi == n:
        lo = min(lo, max(0, n - padlen - 1))
    return lo, hi, padlen if lo == 0 else 0, padlen if hi == n else 0


def _padlen(n: int, rate_hz: float, cutoff_hz: float) -> int:
    # Odd extension over ~3 filter time constants (scipy's default is a few samples): the edge
    # transient of a smooth signal then stays below the noise instead of bending its derivatives.
    return min(n - 1, int(3 * rate_hz / cutoff_hz))


def lowpass_span(
    x: np.ndarray, start: int, stop: int, rate_hz: float, cutoff_hz: float, order: int
) -> np.ndarray:
    """Samples ``[start, stop)`` of :func:`lowpass` ``(x, ...)``, filtering only a window around them."""
    sos = butterworth_sos(order, cutoff_hz, rate_hz)  # checks the cut-off against Nyquist
    lo, hi, before, after = _window(
        x.shape[0], start, stop, settling_samples(sos), _padlen(x.shape[0], rate_hz, cutoff_hz)
    )
    return sosfiltfilt_window(sos, x[lo:hi], before, after)[start - lo : stop - lo]


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
    """Cut-off used (Hz); None: no filter."""
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

    def _filtered_span(self, x: np.ndarray, start: int, stop: int) -> np.ndarray:
        """Working samples ``[start, stop)`` of the raw signal ``x`` low-passed (or not) and thinned."""
        raw_start, raw_stop = start * self.step, (stop - 1) * self.step + 1
        if self.cutoff_hz is None:
            return x[raw_start : raw_stop : self.step]
        rate = self.working_rate_hz * self.step
        return lowpass_span(x, raw_start, raw_stop, rate, self.cutoff_hz, self.order)[:: self.step]

    def states(self, start: int, stop: int, velocity: VelocityChoice | None = None) -> States:
        """States and torques at the working samples ``[start, stop)``, equal to the whole log's.

        ``velocity``: the velocity source (default: :attr:`velocity`).
        """
        choice = self.velocity if velocity is None else velocity
        lo, hi = max(0, start - STATE_HALO), min(self.n_working, stop + STATE_HALO)
        q = self._filtered_span(self.raw_q, lo, hi)
        dt = 1.0 / self.working_rate_hz
        velocities = central_difference(q, dt, self.difference_accuracy)
        if choice.logged and self.raw_dq is not None:
            velocities = choice.apply(self._filtered_span(self.raw_dq, lo, hi))
        accelerations = central_difference(velocities, dt, self.difference_accuracy)
        kept = slice(start - lo, stop - lo)
        return States(
            start,
            self.raw_t[start * self.step : (stop - 1) * self.step + 1 : self.step],
            q[kept],
            velocities[kept],
            accelerations[kept],
            self._filtered_span(self.raw_tau, start, stop),
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
            else f"low-pass {self.cutoff_hz:.3g} Hz (order {self.order}) on q, τ and W"
        )
        return (
            f"{cutoff}; {len(self.index)} rows at {self.rate_hz:.4g} Hz "
            f"(working rate {self.working_rate_hz:.4g} Hz); "
            f"velocity: {self.velocity.describe()}"
        )


_STATE_NAMES = ("t", "q", "dq", "ddq", "tau")


def _block_regressor(regressor: Regressor, states: States) -> tuple[np.ndarray, int]:
    """``(W, P)``: the regressor at every sample of ``states`` as one row per sample (n, N_J·P),
    built :data:`REGRESSOR_SAMPLES` at a time, column-major: the filter reads and writes its
    columns as contiguous runs (row-major, a few columns taken at a time cost it a third more)."""
    n, n_joints = states.q.shape

    def part(first: int) -> np.ndarray:
        chosen = slice(first, first + REGRESSOR_SAMPLES)
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
    for first in range(REGRESSOR_SAMPLES, n, REGRESSOR_SAMPLES):
        w[first : first + REGRESSOR_SAMPLES] = part(first)
    return w, head.shape[1] // n_joints


def lowpass(x: np.ndarray, rate_hz: float, cutoff_hz: float, order: int) -> np.ndarray:
    """Zero-phase Butterworth low-pass along axis 0 (second-order sections, forward-backward)."""
    sos = butterworth_sos(order, cutoff_hz, rate_hz)  # checks the cut-off against Nyquist
    padlen = _padlen(x.shape[0], rate_hz, cutoff_hz)
    return sosfiltfilt_window(sos, x, padlen, padlen)


def central_difference(x: np.ndarray, dt: float, accuracy: int = 2) -> np.ndarray:
    """First derivative along axis 0 by centred differences.

    ``accuracy=2`` is the paper's ``(x[k+1] − x[k−1]) / 2dt``; ``accuracy=4`` uses the five-point
    stencil ``(−x[k+2] + 8x[k+1] − 8x[k−1] + x[k−2]) / 12dt``, whose error (∝ dt⁴) is negligible for
    noiseless data. Ends use second-order one-sided differences.
    """
    derivative = np.gradient(x, dt, axis=0, edge_order=2)
    if accuracy == 4 and x.shape[0] >= 5:
        derivative[2:-2] = (-x[4:] + 8 * x[3:-1] - 8 * x[1:-3] + x[:-4]) / (12 * dt)
    elif accuracy != 2:
        raise ValueError(f"difference accuracy must be 2 or 4, got {accuracy}")
    return derivative


def motion_frequency(q: np.ndarray, rate_hz: float, block_samples: int = 1 << 16) -> float:
    """Frequency of a motion's accelerations (Hz): ‖q̈‖/(2π‖q̇‖) over all joints (exact for a sinusoid).

    It weighs the fast parts of a motion more than the RMS frequency of the positions does, and so
    tells a slow sinusoid from an exciting motion with sharp accelerations. Derivatives of positions
    smoothed at min(20 Hz, rate/5), so encoder noise does not count as motion; the first and last
    half second (smoothing transients) are left out. Computed in blocks of ``block_samples``.
    """
    dt = 1.0 / rate_hz
    n = q.shape[0]
    edge = min(int(0.5 * rate_hz), n // 4)
    speed2 = acceleration2 = 0.0
    halo = 2  # two centred differences
    for start in range(edge, n - edge, block_samples):
        stop = min(n - edge, start + block_samples)
        lo, hi = max(0, start - halo), min(n, stop + halo)
        smooth = lowpass_span(q, lo, hi, rate_hz, min(20.0, rate_hz / 5.0), 2) if n > 12 else q[lo:hi]
        velocity = central_difference(smooth, dt)
        acceleration = central_difference(velocity, dt)
        speed2 += float(np.sum(velocity[start - lo : stop - lo] ** 2))
        acceleration2 += float(np.sum(acceleration[start - lo : stop - lo] ** 2))
    if speed2 == 0.0:
        return 0.0
    return float(np.sqrt(acceleration2) / (2.0 * np.pi * np.sqrt(speed2)))


def auto_cutoff(q: np.ndarray, rate_hz: float) -> float:
    """The automatic cut-off (Hz): 15 × the motion's frequency, within [0.5 Hz, rate/5]."""
    return float(
        np.clip(CUTOFF_PER_MOTION_FREQUENCY * motion_frequency(q, rate_hz), MIN_AUTO_CUTOFF_HZ, rate_hz / 5.0)
    )


def _resolve_cutoff(cutoff_hz: float | str | None, q: np.ndarray, rate: float) -> float | None:
    if cutoff_hz is None:
        return None
    if isinstance(cutoff_hz, str):
        if cutoff_hz != "auto":
            raise ConfigError(
                f"measurement.processing.cutoff_hz must be a number (Hz), auto or null, got {cutoff_hz!r}"
            )
        return auto_cutoff(q, rate)
    cutoff = float(cutoff_hz)
    if not 0.0 < cutoff < rate / 2:
        raise ConfigError(
            f"measurement.processing.cutoff_hz = {cutoff:g} Hz must lie in (0, {rate / 2:g}) Hz, "
            f"the Nyquist band of a {rate:g} Hz measurement "
            "(is the time column in the declared unit? see data.time_unit)"
        )
    return cutoff


def process(
    t: np.ndarray,
    q: np.ndarray,
    tau: np.ndarray,
    dq: np.ndarray | None = None,
    *,
    cutoff_hz: float | str | None = "auto",
    order: int = 5,
    difference_accuracy: int = 2,
    trim_s: float | None = 0.2,
    rate_hz: float | None = None,
    velocity: str = "auto",
    every_sample: bool = False,
    block_s: float | None = DEFAULT_BLOCK_S,
) -> ProcessedData:
    """Filter, differentiate, trim and decimate one measurement (see the module docstring).

    Parameters
    ----------
    t, q, tau : raw times (s), positions (rad) and torques (N·m) on a uniform grid.
    dq : logged velocities (rad/s), or None.
    cutoff_hz : Butterworth cut-off (Hz), ``"auto"`` (15 × the motion's frequency ‖q̈‖/(2π‖q̇‖), see
        :func:`auto_cutoff`), or ``None`` for no filter (noiseless simulations).
    order : Butterworth order.
    difference_accuracy : order of the centred differences, 2 (paper) or 4.
    trim_s : seconds dropped at each end (filter edge transients); None: 2 / cut-off (0 without filter).
    rate_hz : rate of the identification rows (Hz); None: 5 × the cut-off (every sample without filter).
    velocity : ``auto`` (logged velocities where they agree with the positions, see
        :func:`lwrlab.signal.velocity.choose_velocity`), ``logged`` or ``differentiated``.
    every_sample : keep every sample (no working rate, no decimation): the states at which a model
        predicts the logged torques.
    block_s : seconds of log processed at a time (None: the whole log at once); the result does
        not depend on it beyond rounding.
    """
    if velocity not in VELOCITY_SOURCES:
        raise ConfigError(
            f"measurement.processing.velocity must be one of {list(VELOCITY_SOURCES)}, got {velocity!r}"
        )
    if velocity == "logged" and dq is None:
        raise ConfigError(
            "data.velocity=logged, but the log has no velocities (columns dq1…dqN, or a mapped dq array)"
        )
    if block_s is not None and not block_s > 0:
        raise ConfigError(f"measurement.processing.block_s must be positive (s) or null, got {block_s}")
    rate = float((len(t) - 1) / (t[-1] - t[0]))
    cutoff = _resolve_cutoff(cutoff_hz, q, rate)
    # Thin the filtered signals to a working rate (no aliasing: the filter removed what lies above).
    step = (
        max(1, int(np.floor(rate / (WORKING_RATE_PER_CUTOFF * cutoff))))
        if cutoff is not None and not every_sample
        else 1
    )
    working_rate = rate / step
    n_working = -(-len(t) // step)
    block = n_working if block_s is None else max(1, min(n_working, round(block_s * working_rate)))

    trim = (
        (TRIM_PER_CUTOFF_PERIOD / cutoff if cutoff is not None else 0.0) if trim_s is None else float(trim_s)
    )
    first = round(trim * working_rate)
    if 2 * first >= n_working - 1:
        raise ConfigError(
            f"measurement.processing.trim_s: trimming {trim:.3g} s at each end leaves nothing "
            f"of a {t[-1] - t[0]:.3f} s measurement"
        )
    target = (
        rate_hz
        if rate_hz is not None
        else (DECIMATED_RATE_PER_CUTOFF * cutoff if cutoff is not None else working_rate)
    )
    if target <= 0:
        raise ConfigError(f"measurement.processing.rate_hz must be positive, got {target}")
    if cutoff is not None and target < 2.0 * cutoff:
        raise ConfigError(
            f"measurement.processing.rate_hz = {target:g} Hz aliases the {cutoff:g} Hz band: "
            f"give at least {2 * cutoff:g} Hz"
        )
    decimation = 1 if every_sample else max(1, int(np.floor(working_rate / target + 1e-9)))
    data = ProcessedData(
        raw_t=t,
        raw_q=q,
        raw_tau=tau,
        raw_dq=None if velocity == "differentiated" else dq,
        step=step,
        index=np.arange(first, n_working - first, decimation),
        cutoff_hz=cutoff,
        order=order,
        difference_accuracy=difference_accuracy,
        working_rate_hz=working_rate,
        rate_hz=working_rate / decimation,
        velocity=VelocityChoice.differentiated(
            "requested" if velocity == "differentiated" else "no logged velocities"
        ),
        block_samples=block,
    )
    if data.raw_dq is None:
        return data
    # The logged velocities are checked against the derivative of the positions over the whole log.
    pairs = [
        (data._filtered_span(data.raw_dq, b.start, b.start + len(b.t)), b.dq) for b in data.state_blocks()
    ]
    logged = np.concatenate([logged for logged, _ in pairs])
    differentiated = np.concatenate([d for _, d in pairs])
    del pairs
    choice = choose_velocity(logged, differentiated, forced=velocity == "logged")
    return replace(data, velocity=choice, raw_dq=dq if choice.logged else None)
