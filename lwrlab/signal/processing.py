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
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from lwrlab.errors import ConfigError
from lwrlab.signal.velocity import VelocityChoice, choose_velocity
from lwrlab.signal.zero_phase import butterworth_sos, sosfiltfilt

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


@dataclass(frozen=True)
class ProcessedData:
    """A measurement filtered and differentiated, at the working rate, with the identification rows.

    States and torques are given at every working sample (``t``); ``index`` are the samples kept as
    identification rows (trimmed and decimated). :meth:`rows` builds the filtered regressor rows.
    """

    t: np.ndarray
    """(N,) times (s) of the working samples."""
    q: np.ndarray
    """(N, N_J) filtered positions (rad)."""
    dq: np.ndarray
    """(N, N_J) velocities (rad/s)."""
    ddq: np.ndarray
    """(N, N_J) accelerations (rad/s²)."""
    tau: np.ndarray
    """(N, N_J) filtered torques (N·m)."""
    index: np.ndarray
    """(M,) working samples kept as identification rows (trimmed, decimated)."""
    source_index: np.ndarray
    """(N,) index of each working sample in the raw measurement."""
    cutoff_hz: float | None
    """Cut-off used (Hz); None: no filter."""
    order: int
    """Butterworth order."""
    working_rate_hz: float
    """Rate of ``t`` (Hz)."""
    rate_hz: float
    """Rate of the identification rows (Hz)."""
    velocity: VelocityChoice
    """Where the velocities come from, and why."""

    @property
    def filtered(self) -> bool:
        """Whether the torques and the regressor columns are low-passed."""
        return self.cutoff_hz is not None

    @property
    def row_times(self) -> np.ndarray:
        """(M,) times of the identification rows (s)."""
        return self.t[self.index]

    @property
    def raw_index(self) -> np.ndarray:
        """(M,) index of each identification row in the raw measurement."""
        return self.source_index[self.index]

    def rows(
        self, regressor: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray]
    ) -> tuple[np.ndarray, np.ndarray]:
        """The identification rows ``(W, τ)``: ``regressor`` at every working sample, filtered like τ.

        Parameters
        ----------
        regressor : ``(q, q̇, q̈) -> W``, sample-major stacked rows ``(N·N_J, P)``.

        Returns
        -------
        W : (M·N_J, P) filtered regressor rows; tau : (M·N_J,) filtered torques.
        """
        n, n_joints = self.q.shape
        w = regressor(self.q, self.dq, self.ddq)
        columns = w.shape[1]
        w = w.reshape(n, n_joints * columns)
        if self.cutoff_hz is not None:
            w = lowpass(w, self.working_rate_hz, self.cutoff_hz, self.order)
        w = w[self.index].reshape(len(self.index) * n_joints, columns)
        return w, self.tau[self.index].ravel()

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


def lowpass(x: np.ndarray, rate_hz: float, cutoff_hz: float, order: int) -> np.ndarray:
    """Zero-phase Butterworth low-pass along axis 0 (second-order sections, forward-backward)."""
    sos = butterworth_sos(order, cutoff_hz, rate_hz)  # checks the cut-off against Nyquist
    # Odd extension over ~3 filter time constants (scipy's default is a few samples): the edge
    # transient of a smooth signal then stays below the noise instead of bending its derivatives.
    padlen = min(x.shape[0] - 1, int(3 * rate_hz / cutoff_hz))
    return sosfiltfilt(sos, x, padlen)


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


def motion_frequency(q: np.ndarray, rate_hz: float) -> float:
    """Frequency of a motion's accelerations (Hz): ‖q̈‖/(2π‖q̇‖) over all joints (exact for a sinusoid).

    It weighs the fast parts of a motion more than the RMS frequency of the positions does, and so
    tells a slow sinusoid from an exciting motion with sharp accelerations. Derivatives of positions
    smoothed at min(20 Hz, rate/5), so encoder noise does not count as motion; the first and last
    half second (smoothing transients) are left out.
    """
    dt = 1.0 / rate_hz
    smooth = lowpass(q, rate_hz, min(20.0, rate_hz / 5.0), 2) if q.shape[0] > 12 else q
    velocity = central_difference(smooth, dt)
    acceleration = central_difference(velocity, dt)
    edge = min(int(0.5 * rate_hz), q.shape[0] // 4)
    speed = np.linalg.norm(velocity[edge : q.shape[0] - edge])
    if speed == 0.0:
        return 0.0
    return float(np.linalg.norm(acceleration[edge : q.shape[0] - edge]) / (2.0 * np.pi * speed))


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
    """
    if velocity not in VELOCITY_SOURCES:
        raise ConfigError(
            f"measurement.processing.velocity must be one of {list(VELOCITY_SOURCES)}, got {velocity!r}"
        )
    if velocity == "logged" and dq is None:
        raise ConfigError(
            "data.velocity=logged, but the log has no velocities (columns dq1…dqN, or a mapped dq array)"
        )
    rate = float((len(t) - 1) / (t[-1] - t[0]))
    cutoff = _resolve_cutoff(cutoff_hz, q, rate)
    if cutoff is not None:
        q = lowpass(q, rate, cutoff, order)
        tau = lowpass(tau, rate, cutoff, order)
        if dq is not None and velocity != "differentiated":
            dq = lowpass(dq, rate, cutoff, order)
    # Thin the filtered signals to a working rate (no aliasing: the filter removed what lies above).
    step = (
        max(1, int(np.floor(rate / (WORKING_RATE_PER_CUTOFF * cutoff))))
        if cutoff is not None and not every_sample
        else 1
    )
    source_index = np.arange(0, len(t), step)
    t, q, tau = t[source_index], q[source_index], tau[source_index]
    working_rate = rate / step
    dt = 1.0 / working_rate
    differentiated = central_difference(q, dt, difference_accuracy)
    velocities = differentiated
    if dq is None or velocity == "differentiated":
        choice = VelocityChoice.differentiated(
            "requested" if velocity == "differentiated" else "no logged velocities"
        )
    else:
        choice = choose_velocity(dq[source_index], differentiated, forced=velocity == "logged")
        if choice.logged:
            velocities = choice.apply(dq[source_index])
    accelerations = central_difference(velocities, dt, difference_accuracy)

    trim = (
        (TRIM_PER_CUTOFF_PERIOD / cutoff if cutoff is not None else 0.0) if trim_s is None else float(trim_s)
    )
    first = round(trim * working_rate)
    if 2 * first >= len(t) - 1:
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
    index = np.arange(first, len(t) - first, decimation)
    return ProcessedData(
        t=t,
        q=q,
        dq=velocities,
        ddq=accelerations,
        tau=tau,
        index=index,
        source_index=source_index,
        cutoff_hz=cutoff,
        order=order,
        working_rate_hz=working_rate,
        rate_hz=working_rate / decimation,
        velocity=choice,
    )
