"""Laser detector: a learned whole-scan person detector (DROW3 / DR-SPAAM style), run with NumPy.

For every return within the model's range (:func:`pfpeople.detect.learned.cutouts.centre_beams`) the detector cuts
the scan around it (:func:`~pfpeople.detect.learned.cutouts.cutouts`: a fixed metric window, range-normalised, with
the no-return beams as free space), and, for a temporal model, cuts each of the last scans around the same point
moved into that scan's frame by the ego-motion. The network (:mod:`pfpeople.detect.learned.net`) gives each return
a person probability ``s = sigmoid(logit)`` and a vote for the person's centre; the votes are grouped into people
(:func:`pfpeople.detect.learned.votes.group_votes`), each with the score of its best vote. People scoring at least
the operating threshold are reported (centres, not legs). Where the model card holds ``calibration.ppv_by_score``
(:mod:`pfpeople.detect.score_ppv`, measured on the held-out folds), each reported person also carries the PPV its
score earned there (:meth:`LearnedPeopleDetector.detect_with_ppv`), which the filters fuse instead of the one PPV.

Temporal models need the laser frame's motion between scans (:meth:`LearnedPeopleDetector.observe_motion`): without
it (the first scan, an odometry gap, a failed scan match) the past scans are forgotten and the current scan stands in
for them, as the model saw during training.

The shipped model (``pfpeople/models/learned_people.npz`` and its model card ``learned_people.json``: data, folds,
figures, lasers) loads by default; ``pfpeople train-detector --kind learned`` makes another
(:mod:`pfpeople.detect.learned.training`, needs the ``[train]`` extra).
"""

from __future__ import annotations

from importlib import resources
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from gridbridge.geometry import Pose2D
from gridbridge.params import DetectorModel
from gridbridge.validation import check_number
from pfpeople.detect.learned.memory import ScanMemory
from pfpeople.detect.learned.model_file import LearnedModel, load_model
from pfpeople.detect.learned.votes import group_votes, vote_positions
from pfpeople.detect.motion import compose_pending
from pfpeople.detect.score_ppv import ScorePpv
from pfpeople.sensors import LaserScan

__all__ = ["DEFAULT_LEARNED_MODEL", "LearnedPeopleDetector", "default_learned_model_path"]

DEFAULT_LEARNED_MODEL = "learned_people"


def default_learned_model_path() -> Path:
    """Path of the shipped model ``pfpeople/models/learned_people.npz``."""
    return Path(str(resources.files("pfpeople.models").joinpath(f"{DEFAULT_LEARNED_MODEL}.npz")))


def _sigmoid(x: NDArray[np.float32]) -> NDArray[np.float64]:
    return 1.0 / (1.0 + np.exp(-np.clip(x.astype(np.float64), -60.0, 60.0)))


class LearnedPeopleDetector:
    """People from the whole scan by a learned network (module docstring).

    Parameters
    ----------
    model_path : str or Path, optional
        A model written by ``pfpeople train-detector --kind learned`` (``.npz`` with its ``.json`` card beside it).
        Default: the shipped model (:meth:`from_model` takes one already loaded).
    threshold : float, optional
        Report people scoring at least this (0-1); default the model card's operating threshold.
    model : DetectorModel, optional
        PPV / FNR and field of view for the filters; default the values in the model card (measured on held-out
        folds), 180 deg.
    score_ppv : bool
        Each reported person carries the PPV of its score (the card's ``calibration.ppv_by_score``) for the filters
        to fuse (:meth:`detect_with_ppv`); False, or a card without it: the model's one PPV holds for all.
    """

    def __init__(
        self,
        model_path: str | Path | None = None,
        *,
        threshold: float | None = None,
        model: DetectorModel | None = None,
        score_ppv: bool = True,
    ) -> None:
        if model_path is not None and not isinstance(model_path, str | Path):
            raise TypeError(f"model_path must be a path, got {model_path!r} ({type(model_path).__name__})")
        learned = load_model(default_learned_model_path() if model_path is None else model_path)
        self._setup(learned, threshold, model, score_ppv)

    @classmethod
    def from_model(
        cls,
        learned: LearnedModel,
        *,
        threshold: float | None = None,
        model: DetectorModel | None = None,
        score_ppv: bool = True,
    ) -> LearnedPeopleDetector:
        """A detector of a model already loaded or just trained (arguments as the constructor's)."""
        det = cls.__new__(cls)
        det._setup(learned, threshold, model, score_ppv)
        return det

    def _setup(
        self, learned: LearnedModel, threshold: float | None, model: DetectorModel | None, score_ppv: bool
    ) -> None:
        if not isinstance(score_ppv, bool):
            raise TypeError(f"score_ppv must be True or False, got {score_ppv!r}")
        self.learned: LearnedModel = learned
        if threshold is not None:
            threshold = check_number(threshold, "threshold")
            if not 0.0 <= threshold <= 1.0:
                raise ValueError(f"threshold must be in [0, 1], got {threshold}")
        self.threshold = float(self.learned.threshold if threshold is None else threshold)
        self.model = model if model is not None else _card_model(self.learned)
        #: ``PPV(score)`` of the card (None: not measured, or ``score_ppv`` off).
        self.score_ppv: ScorePpv | None = _card_score_ppv(self.learned) if score_ppv else None
        self.memory = ScanMemory(self.learned.past_scans, self.learned.past_step, motion=self.learned.motion_input)
        self._motion: Pose2D | None = None
        self._given = False

    @property
    def uses_ego_motion(self) -> bool:
        """Whether the model looks at past scans or moved returns (and so needs :meth:`observe_motion` before every
        scan)."""
        return self.learned.past_scans > 0 or self.learned.motion_input

    def reset(self) -> None:
        """Forget the past scans (a new recording, or a jump in time)."""
        self.memory.clear()
        self._motion = None
        self._given = False

    def observe_motion(self, motion: Pose2D | None) -> None:
        """The laser frame's motion since the previous scan (the new frame in the previous one; m, rad), or None
        when unknown (the past scans are then forgotten). Call before :meth:`detect` of the new scan; motions given
        for frames whose scan never reached :meth:`detect` are composed with the next one."""
        self._motion = compose_pending(self._motion, motion, self._given)
        self._given = True

    def votes(self, scan: LaserScan) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Every looked-at return's vote: centres ``(C, 2)`` (m, scan frame) and probabilities ``(C,)``."""
        self.memory.advance(scan, self._motion)
        self._motion, self._given = None, False
        idx, x = self.memory.inputs(scan, self.learned.cutout)
        if idx.size == 0:
            return np.zeros((0, 2)), np.zeros(0)
        out = self.learned.network(x)
        pos = vote_positions(scan.angles[idx], scan.ranges[idx], out[:, 1:].astype(np.float64))
        return pos, _sigmoid(out[:, 0])

    def detect_scored(self, scan: LaserScan) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Every grouped person, reported or not: centres ``(M, 2)`` (m, scan frame) and scores ``(M,)``,
        best first (for precision-recall curves)."""
        pos, prob = self.votes(scan)
        return group_votes(pos, prob, radius=self.learned.group_radius, min_score=self.learned.min_vote)

    def _reported(self, scan: LaserScan) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The people scoring at least :attr:`threshold`: centres ``(M, 2)`` and scores ``(M,)``."""
        centres, scores = self.detect_scored(scan)
        keep = scores >= self.threshold
        return centres[keep], scores[keep]

    def detect(self, scan: LaserScan) -> NDArray[np.float64]:
        """People ``(M, 2)`` (m, scan frame) scoring at least :attr:`threshold`."""
        return self._reported(scan)[0]

    def detect_with_ppv(self, scan: LaserScan) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
        """:meth:`detect`'s people ``(M, 2)`` (m, scan frame) and the PPV of each one's score ``(M,)``
        (:attr:`score_ppv`; None without it)."""
        centres, scores = self._reported(scan)
        return centres, None if self.score_ppv is None else self.score_ppv(scores)


def _card_model(learned: LearnedModel) -> DetectorModel:
    """The detector model of the card's ``calibration`` (PPV / FNR measured on held-out folds)."""
    cal = learned.card.get("calibration", {})
    if not isinstance(cal, dict) or "ppv" not in cal or "fnr" not in cal:
        raise ValueError(f"model card of {learned.path}: no calibration (ppv, fnr) measured on held-out data")
    return DetectorModel(name="laser_learned", ppv=float(cal["ppv"]), fnr=float(cal["fnr"]))


def _card_score_ppv(learned: LearnedModel) -> ScorePpv | None:
    """The card's ``calibration.ppv_by_score`` (None when the card has none)."""
    entry = learned.card.get("calibration", {}).get("ppv_by_score")
    return None if entry is None else ScorePpv.from_card(entry, f"model card of {learned.path}")
