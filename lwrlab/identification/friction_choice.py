"""The friction law, its shape and the rotor-inertia columns, chosen by block cross-validation.

``friction=auto`` offers candidate laws (each point of their shape grids) and, with the robot's
``drive.rotor_inertia: auto``, each with and without the rotor-inertia columns. Which predicts the
robot best is a question for data it was not fitted on, so every candidate is scored on contiguous
held-out blocks of the identification rows, as the prior's weight is
(:mod:`lwrlab.identification.prior_weight`).

One pass over the logs serves every candidate: the rows are built once with the inertial base
columns and the union of every candidate's drive columns (:func:`_families`), filtered as the
identification filters its rows, and reduced to one Gram matrix per fold and joint. A candidate's
fit on four folds and its error on the fifth are then small dense solves on a subset of that
matrix's rows and columns. The fits are least squares with each joint's rows scaled by its torque
level (so a wrist counts as much as a shoulder) and a small ridge toward the CAD values
(:data:`RIDGE`); the score is the held-out squared error relative to each joint's torque energy,
averaged over the joints.
The choice is the simplest candidate within one standard error of the best, on the mean held-out
error or on the mean of the mean and the worst held-out fold (:func:`_one_standard_error`). Simplest
counts the columns, then whether the data picked a shape setting from a grid (a ``smooth`` law whose
width was chosen among four is not as simple as ``sign``), then the order of the laws. A more
complex law must also beat the simpler ones by more than a share of the noise its scores hold
(:data:`NOISE_MATERIALITY`): on noisy logs a few per cent of held-out error between two laws is
the noise's, not the laws'.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import pandas as pd

from lwrlab.dynamics.base_parameters import BaseParameters
from lwrlab.dynamics.friction_regressor import fill_friction_regressor
from lwrlab.dynamics.regressor import regressor
from lwrlab.model.friction_laws import (
    FrictionLaw,
    describe_law,
    drive_loads,
    has_load,
    has_memory,
    history_columns,
    history_window,
)
from lwrlab.model.robot import RobotModel
from lwrlab.signal.processing import ProcessedData
from lwrlab.signal.rest import speed_noise as joint_speed_noise
from lwrlab.signal.rest import third_difference_mad

RIDGE = 1e-6
"""Ridge of the cross-validation fits toward the robot's own (CAD) base parameters, relative to the
diagonal of the Gram matrix: it holds the directions a few folds of a user's log barely excite,
which least squares would otherwise extrapolate wildly into the held-out fold."""
MAX_SAMPLES = 120_000
"""Most working samples (2 min at 1 kHz) whose rows are scored, the first of each log beyond: every
candidate's columns are filtered at every working sample, and the choice needs the shape of the
data, not every sample of an hour-long log."""
NOISE_MATERIALITY = 0.2
"""Share of the torque noise's part of the held-out score (:func:`torque_noise_share`) by which a more
complex candidate must beat the best to be preferred to a simpler one: on logs whose held-out error
is mostly noise, a law that fits a few per cent of it better has fitted the motion's noise (the
velocity's and the torque's, filtered alike), not the robot (a MuJoCo arm with the paper's law:
``smooth`` led ``sign`` by 4 % of NRMS and predicted its true torque 3 × worse)."""
CHOICE_BLOCK = 4096
"""Working samples per block of the choice's rows: every candidate's columns side by side (~250)
would make the usual blocks hundreds of megabytes."""


@dataclass(frozen=True)
class FrictionCandidate:
    """A friction law with its shape fixed, with or without the rotor-inertia columns."""

    law: FrictionLaw
    rotor: bool
    picked_settings: int = 0
    """Shape settings of the law picked from a grid (each a degree of freedom the data spent)."""

    @property
    def label(self) -> str:
        """``smooth (width 0.01) + rotor``."""
        return describe_law(self.law) + (" + rotor inertia" if self.rotor else "")


@dataclass(frozen=True)
class FrictionChoice:
    """The candidates' held-out errors and the one chosen."""

    candidates: tuple[FrictionCandidate, ...]
    scores: np.ndarray
    """(C,) held-out relative squared error of each candidate, mean over joints."""
    chosen: int
    speed_noise: np.ndarray
    """(N_D,) speed noise of the drives in the logs (rad/s), what noise-width laws read."""
    columns: np.ndarray | None = None
    """(C,) drive columns of each candidate per drive."""
    eligible: np.ndarray | None = None
    """(C,) bool: within one standard error (and the noise's materiality) of the best."""
    noise_share: float = 0.0
    """The torque noise's part of the held-out scores (relative squared error, mean over joints)."""

    @property
    def candidate(self) -> FrictionCandidate:
        """The chosen candidate."""
        return self.candidates[self.chosen]

    def table(self) -> pd.DataFrame:
        """One row per candidate: its held-out NRMS (%, root of the score) and whether it was chosen."""
        return pd.DataFrame(
            {
                "candidate": [c.label for c in self.candidates],
                "law": [c.law.name for c in self.candidates],
                "rotor_inertia": [c.rotor for c in self.candidates],
                "cv_nrms_percent": 100.0 * np.sqrt(self.scores),
                "chosen": [k == self.chosen for k in range(len(self.candidates))],
            }
        )

    def describe(self) -> str:
        """One line for the report: the choice, its held-out NRMS and why it was chosen over the lower
        ones (the one-standard-error rule keeps the simplest candidate the data do not reject)."""
        nrms = 100.0 * np.sqrt(self.scores)
        order = [k for k in np.argsort(self.scores) if k != self.chosen]
        lower = [k for k in order if self.scores[k] < self.scores[self.chosen]]
        head = (
            f"friction chosen by {len(self.candidates)}-candidate block cross-validation: "
            f"{self.candidate.label} (held-out NRMS {nrms[self.chosen]:.2f} %"
        )
        if not lower:
            rest = ", ".join(f"{self.candidates[k].label} {nrms[k]:.2f} %" for k in order[:2])
            return f"{head}, the lowest; next: {rest})"
        beaten = ", ".join(f"{self.candidates[k].label} {nrms[k]:.2f} %" for k in lower[:2])
        more = f" and {len(lower) - 2} more" if len(lower) > 2 else ""
        noise = (
            f" (or {NOISE_MATERIALITY:g} × the noise's share of it, {100 * np.sqrt(self.noise_share):.2f} %)"
            if self.noise_share > 0
            else ""
        )
        return (
            f"{head}; lower: {beaten}{more}): the simplest law within one standard error of the best"
            f"{noise} is kept (one-standard-error rule: a law with more columns, or shape settings "
            "picked from a grid, must beat the simpler ones by more than the folds' scatter)"
        )


def speed_noise(processed: Sequence[ProcessedData], robot: RobotModel) -> np.ndarray:
    """(N_D,) noise of the processed drive speeds (rad/s): the encoder noise through the processing.

    The position noise σ_q of each joint comes from the raw samples' third differences (blind to
    motions up to quadratic in time: ``var(Δ³q) = 20·σ_q²``, a robust MAD estimate); the processing's
    zero-phase low-pass of the positions at ``f_c`` and the differentiation make it a speed noise of
    ``σ_q·2π·√(2·f_c³ / (3·f_s))`` (white noise through an ideal low-pass and a derivative), or
    ``σ_q·f_s/√2`` without a filter (centred differences).
    """
    variances = [
        joint_speed_noise(data.raw_q, data.working_rate_hz * data.step, data.state_cutoff_hz) ** 2
        for data in processed
        if len(data.raw_q) >= 8
    ]
    joint_variance = np.mean(variances, axis=0) if variances else np.zeros(robot.n_joints)
    coupling = robot.drive_train.coupling
    return np.sqrt(np.square(coupling) @ joint_variance)


def _picked_settings(laws: Sequence[FrictionLaw]) -> list[int]:
    """Per law, the shape settings that differ among the candidates of its kind: picked from a grid."""
    counts = []
    for law in laws:
        kind = [other.settings() for other in laws if type(other) is type(law)]
        counts.append(sum(len({repr(s.get(key)) for s in kind}) > 1 for key in law.settings()))
    return counts


def friction_candidates(robot: RobotModel, noise: np.ndarray) -> tuple[FrictionCandidate, ...]:
    """The robot's law's candidates, with and without rotor inertias when its drive says ``auto``
    and there is a choice to make at all."""
    laws = robot.friction_law.candidates(noise)
    rotor = robot.drive_train.rotor_inertia_columns
    options = ((False, True) if len(laws) > 1 else (False,)) if rotor == "auto" else (bool(rotor),)
    picked = _picked_settings(laws)
    return tuple(FrictionCandidate(law, r, p) for law, p in zip(laws, picked, strict=True) for r in options)


def torque_noise_share(processed: Sequence[ProcessedData], grams: np.ndarray) -> float:
    """The torque noise's part of the held-out scores: per joint, the raw torques' noise variance
    (third differences, a robust MAD estimate, as :func:`speed_noise`) through the processing's
    zero-phase low-pass, times the rows, over the joint's torque energy in the rows (``grams``
    (folds, N_J, P+1, P+1)); the mean over the joints that have torque."""
    variances, weights = [], []
    for data in processed:
        if len(data.raw_tau) < 8 or not data.index.size:
            continue
        sigma2 = third_difference_mad(data.raw_tau) ** 2 / 20.0
        rate = data.working_rate_hz * data.step
        variances.append(sigma2 * _filter_noise_gain(data.cutoff_hz, rate, data.order))
        weights.append(len(data.index))
    energy = grams[:, :, -1, -1].sum(axis=0)
    if not variances or not np.any(energy > 0):
        return 0.0
    noise = np.average(variances, axis=0, weights=weights) * sum(weights)
    scored = energy > 0
    return float(np.mean(noise[scored] / energy[scored]))


def _filter_noise_gain(cutoff_hz: float | None, rate_hz: float, order: int) -> float:
    """Variance gain of white noise through the zero-phase Butterworth low-pass (forward and back:
    ``|H|⁴``), ``(2/f_s)·∫ df / (1 + (f/f_c)^2n)²`` over [0, f_s/2]; 1 without a filter."""
    if cutoff_hz is None:
        return 1.0
    f = np.linspace(0.0, rate_hz / 2.0, 8193)
    response = 1.0 / (1.0 + (f / cutoff_hz) ** (2 * order)) ** 2
    return float(min(1.0, 2.0 / rate_hz * np.sum(response) * (f[1] - f[0])))


def _terms(robot: RobotModel, candidate: FrictionCandidate) -> tuple[str, ...]:
    return robot.with_friction_law(candidate.law, candidate.rotor).friction_terms


def _family_key(law: FrictionLaw, term: str) -> tuple[object, ...]:
    """Columns that do not depend on the law (viscous, offset, rotor) are shared by every candidate."""
    if term in ("viscous", "offset", "rotor"):
        return (term,)
    return (term, type(law).__qualname__, repr(sorted(law.settings().items())))


def _families(
    robot: RobotModel, candidates: Sequence[FrictionCandidate]
) -> tuple[list[tuple[FrictionLaw, str]], list[list[int]]]:
    """The distinct drive-column families of all candidates, and each candidate's families in order."""
    keys: dict[tuple[object, ...], int] = {}
    families: list[tuple[FrictionLaw, str]] = []
    used = []
    for candidate in candidates:
        own = []
        for term in _terms(robot, candidate):
            key = _family_key(candidate.law, term)
            if key not in keys:
                keys[key] = len(families)
                families.append((candidate.law, term))
            own.append(keys[key])
        used.append(own)
    return families, used


def _fold_grams(
    robot: RobotModel,
    inertial_columns: np.ndarray,
    families: list[tuple[FrictionLaw, str]],
    processed: Sequence[ProcessedData],
    folds: int,
) -> np.ndarray:
    """(folds, N_J, P+1, P+1) Gram matrices of ``[W τ]`` per fold and joint, W = inertial base columns
    then every family's N_D columns."""
    n = robot.n_joints
    bare = replace(robot, friction_terms=())
    width = len(inertial_columns) + n * len(families)
    drive = robot.drive_train

    memory = any(has_memory(law) for law, _ in families)
    loaded = any(has_load(law) for law, _ in families)
    prior = robot.link_parameters.ravel()  # a load-dependent law's load: the prior's rigid bodies

    class Rows:
        """Every family's columns at a run of one log's samples (a law with memory: from the whole log)."""

        takes_start = True
        chunk_samples = 1024  # every candidate's columns: a quarter of the usual chunk, ~16 MB

        def __init__(self, data: ProcessedData) -> None:
            # the rows' windows end within a block (and its filter's padding) of the last row
            stop = int(data.index[-1]) + 2 * data.block_samples if data.index.size else 0
            v = drive.drive_values(data.velocities(stop)) if memory else None
            dt = 1.0 / data.working_rate_hz
            histories: dict[int, dict[str, np.ndarray] | None] = {}  # one per law, shared by its terms
            for law, _ in families:
                if v is not None and id(law) not in histories:
                    histories[id(law)] = history_columns(law, v, dt)
            self.history = [histories.get(id(law)) for law, _ in families]

        def __call__(self, q: np.ndarray, dq: np.ndarray, ddq: np.ndarray, start: int = 0) -> np.ndarray:
            full = np.zeros((q.shape[0], n, width))
            inertial = regressor(bare, q, dq, ddq, stacked=False)
            full[:, :, : len(inertial_columns)] = inertial[:, :, inertial_columns]
            load = drive_loads(drive, inertial @ prior) if loaded else None
            for f, (law, term) in enumerate(families):
                part = history_window(self.history[f], start, len(q))
                first = len(inertial_columns) + f * n
                fill_friction_regressor(
                    dq, (term,), full, first, law=law, drive=drive, ddq=ddq, history=part, load=load
                )
            return full.reshape(-1, width)

    share = min(1.0, MAX_SAMPLES / max(sum(d.n_working for d in processed), 1))  # long logs: their start
    kept = [
        replace(
            d, index=d.index[d.index < max(share * d.n_working, d.index[0] + 1)], block_samples=CHOICE_BLOCK
        )
        for d in processed
        if d.index.size
    ]
    total = sum(len(d.index) for d in kept)
    grams = np.zeros((folds, n, width + 1, width + 1))
    seen = 0
    for data in kept:
        for block in data.row_blocks(Rows(data)):
            _add_to_grams(grams, block.w.reshape(-1, n, width), block.tau.reshape(-1, n), seen, total)
            seen += block.w.shape[0] // n
            del block  # before the next block is built: two blocks of ~250 columns would double the peak
    return grams


def _add_to_grams(grams: np.ndarray, w: np.ndarray, tau: np.ndarray, seen: int, total: int) -> None:
    """Add the rows ``w`` (samples, N_J, P), ``tau`` (samples, N_J), the samples from ``seen`` of
    ``total``, to the Gram matrices ``grams`` (folds, N_J, P+1, P+1) of their folds, in place.

    A fold is a contiguous run of samples, so each fold's rows are a strided view (no copy of a block
    of every candidate's columns), one BLAS product per fold and joint."""
    folds, width = grams.shape[0], w.shape[2]
    fold = np.minimum((seen + np.arange(w.shape[0])) * folds // total, folds - 1)
    for f in np.unique(fold):
        rows = slice(int(np.searchsorted(fold, f)), int(np.searchsorted(fold, f, side="right")))
        for j in range(w.shape[1]):
            a, t = w[rows, j], tau[rows, j]
            grams[f, j, :width, :width] += a.T @ a
            cross = a.T @ t
            grams[f, j, :width, width] += cross
            grams[f, j, width, :width] += cross
            grams[f, j, width, width] += t @ t


def _fold_scores(gram: np.ndarray, columns: np.ndarray, prior: np.ndarray) -> np.ndarray:
    """(folds,) held-out relative squared error of each fold, mean over joints, of least squares on
    ``columns`` of the fold-and-joint Gram matrices ``gram`` (folds, N_J, P+1, P+1), fitted on the
    other folds with a ridge toward ``prior`` (values of every column of the Gram matrices)."""
    folds = gram.shape[0]
    index = np.append(columns, gram.shape[-1] - 1)
    sub = gram[:, :, index[:, None], index[None, :]]
    # each joint's torque energy over the whole log: a fold where a joint barely moves (a rest) is
    # scored against the joint's usual torque, not against its own small one
    energy = sub[:, :, -1, -1].sum(axis=0)  # (N_J,)
    scored = energy > 0.0  # a joint left out of the fit has no rows
    energy = np.where(scored, energy, 1.0)
    weights = 1.0 / energy
    scores = np.zeros(folds)
    for f in range(folds):
        g = np.einsum("j,fjik->ik", weights, sub[np.delete(np.arange(folds), f)])
        a, b = g[:-1, :-1], g[:-1, -1]
        scale = np.sqrt(np.maximum(np.diag(a), 1e-300))
        a_scaled = a / scale[:, None] / scale[None, :]
        a_scaled[np.diag_indices_from(a_scaled)] += RIDGE
        start = prior[columns] * scale  # the prior in scaled units
        x = np.append(np.linalg.solve(a_scaled, b / scale + RIDGE * start) / scale, -1.0)
        held_out = np.einsum("i,jik,k->j", x, sub[f], x) / (energy / folds)  # equal folds
        scores[f] = np.mean(held_out[scored])
    return scores


def _one_standard_error(
    fold_scores: np.ndarray, complexity: Sequence[tuple[int, ...]], noise_share: float = 0.0
) -> tuple[int, np.ndarray]:
    """The simplest candidate (lowest ``complexity``: columns, whether a shape was picked from a grid, order)
    within one standard error of the best one, on either of two scores: the mean held-out error, and
    the mean of the mean and the worst held-out fold; and which candidates were within.

    Hastie et al.'s rule (block cross-validation within the fitted motions favours extra columns that
    new motions do not reward), with a second look at the fold least like the rest (a fast stretch of
    a slow log), which stands for the motions unlike the fitted ones that the model will predict. A
    candidate with more columns is kept only where it beats the simpler ones by more than a standard
    error on both: a law with more shape (a Dahl presliding distance, a Stribeck speed) that wins the
    folds of one repeating motion but loses the odd one out is not worth its columns. Fitted on the
    slow real LWR4+ run, such a law led the mean by more than one standard error, lost the worst fold,
    and predicted the faster run 1 point worse than ``sign``. Each standard error is that of a
    candidate's fold-by-fold difference from the best of that score, over the folds; the margin is at
    least :data:`NOISE_MATERIALITY` × ``noise_share`` (the torque noise's part of the scores).
    """
    mean = fold_scores.mean(axis=1)
    eligible = np.zeros(len(mean), dtype=bool)
    for scores in (mean, (mean + fold_scores.max(axis=1)) / 2.0):
        best = int(np.argmin(scores))
        difference = fold_scores - fold_scores[best]
        standard_error = difference.std(axis=1, ddof=1) / np.sqrt(fold_scores.shape[1])
        margin = np.maximum(standard_error, NOISE_MATERIALITY * noise_share)
        eligible |= scores <= scores[best] + margin
    chosen = min((int(k) for k in np.flatnonzero(eligible)), key=lambda k: complexity[k])
    return chosen, eligible


def choose_friction(
    robot: RobotModel,
    base: BaseParameters,
    processed: Sequence[ProcessedData],
    folds: int = 5,
    joints: np.ndarray | None = None,
) -> tuple[RobotModel, FrictionChoice | None]:
    """The robot with the friction law and rotor columns the data choose, and the choice (None: nothing
    to choose — one law, rotor columns on or off as configured; the robot is returned with them).

    ``joints`` (N_J,) bool: the joints whose torques are fitted and scored (None: all)."""
    noise = speed_noise(processed, robot)
    candidates = friction_candidates(robot, noise)
    if len(candidates) == 1:
        only = candidates[0]
        return robot.with_friction_law(only.law, only.rotor), None
    n_inertial = 10 * robot.n_links
    inertial_columns = base.columns[base.columns < n_inertial]
    families, used = _families(robot, candidates)
    grams = _fold_grams(robot, inertial_columns, families, processed, folds)
    if joints is not None:
        grams[:, ~np.asarray(joints, dtype=bool)] = 0.0
    n = robot.n_joints
    n_base = len(inertial_columns)
    prior = np.zeros(grams.shape[-1] - 1)  # friction, offsets and rotor inertias: 0
    prior[:n_base] = base.base_values(robot.parameters)[base.columns < n_inertial]
    fold_scores = np.array(
        [
            _fold_scores(
                grams,
                np.concatenate([np.arange(n_base), *[n_base + f * n + np.arange(n) for f in own]]).astype(
                    int
                ),
                prior,
            )
            for own in used
        ]
    )
    columns = np.array([len(own) for own in used])
    # a law the data picked no shape for is simpler than one they did (sign before a width from a grid)
    complexity = [(int(columns[k]), int(c.picked_settings > 0), k) for k, c in enumerate(candidates)]
    noise_share = torque_noise_share(processed, grams)
    chosen, eligible = _one_standard_error(fold_scores, complexity, noise_share)
    choice = FrictionChoice(
        candidates, fold_scores.mean(axis=1), chosen, noise, columns, eligible, noise_share
    )
    return robot.with_friction_law(choice.candidate.law, choice.candidate.rotor), choice
