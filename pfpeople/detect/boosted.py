"""Laser detector 2: a learned segment classifier (boosted features, Arras et al. 2007; Spinello & Siegwart 2008).

Every segment of the scan (:mod:`pfpeople.detect.segments`) is described by the geometric features of
:data:`~pfpeople.detect.segments.FEATURE_NAMES` and scored by an OpenCV ``cv2.ml.Boost`` classifier trained
on labelled LEG segments (:mod:`pfpeople.detect.training`, command ``pfpeople train-detector``). Segments
with a score above ``threshold`` are legs; legs become people with the same pairing as the leg-pattern detector
(:func:`pfpeople.detect.legs.people_from_legs`: legs-together segments alone, pairs at 0.1-0.6 m, optional
single legs).

The shipped model ``pfpeople/models/boosted_legs.yml`` (with its JSON sidecar of data, parameters, metrics and
leave-one-bag-out evaluation) is trained on all six labelled leg_tracker bags, negative_2 and the simulated bags of
:mod:`evaluation.scenarios.scan.training_scenes` (a moving robot among furniture and people who stand and walk, as
lasers are specified; ``make model``), and loads by default through ``importlib.resources``. Single legs
(``PairingParams.count_single_legs``) are off by default, as for the leg-pattern detector (figures in
:mod:`pfpeople.detect.legs`).
"""

from __future__ import annotations

import json
import re
from importlib import resources
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from gridbridge.params import CALIBRATED_LASER_DETECTORS, DetectorModel
from gridbridge.validation import check_number
from pfpeople.detect.boost_trees import BoostTrees, check_model_values, load_trees
from pfpeople.detect.legs import PairingParams, people_and_single_legs
from pfpeople.detect.segments import FEATURE_NAMES, SegmentationParams
from pfpeople.detect.training import boost_scores as _opencv_scores
from pfpeople.detect.training import scan_features
from pfpeople.sensors import LaserScan

__all__ = ["DEFAULT_MODEL_NAME", "BoostedSegmentDetector", "default_model_path"]

DEFAULT_MODEL_NAME = "boosted_legs"


def default_model_path() -> Path:
    """Path of the shipped model file ``pfpeople/models/boosted_legs.yml``."""
    ref = resources.files("pfpeople.models").joinpath(f"{DEFAULT_MODEL_NAME}.yml")
    return Path(str(ref))


def _load_boost(path: Path) -> Any:
    """Load an OpenCV Boost model; any failure is a ValueError naming the file."""
    expect = f"a trained OpenCV Boost model (.yml/.xml from `pfpeople train-detector`) on {len(FEATURE_NAMES)} features"
    try:
        with path.open("rb") as fh:
            head = fh.read(4096)
    except OSError as exc:
        raise ValueError(f"boosted model file {str(path)!r} cannot be read: {exc}") from None
    if not head.lstrip().startswith((b"%YAML", b"<?xml", b"{")):
        raise ValueError(f"boosted model file {str(path)!r} is not {expect} (it starts with {head[:16]!r})")
    # OpenCV can crash (not raise) on a storage file without a model: check its structure first
    found = re.search(rb"var_count\W*\s*(\d+)", head)
    if b"opencv_ml_boost" not in head or found is None:
        raise ValueError(f"boosted model file {str(path)!r} is not {expect} (no opencv_ml_boost / var_count)")
    if int(found.group(1)) != len(FEATURE_NAMES):
        raise ValueError(
            f"boosted model file {str(path)!r} has var_count {int(found.group(1))}; this version computes "
            f"{len(FEATURE_NAMES)} features ({', '.join(FEATURE_NAMES)})"
        )
    try:
        boost = cv2.ml.Boost.load(str(path))
        ok = boost is not None and boost.isTrained() and boost.getVarCount() == len(FEATURE_NAMES)
    except cv2.error as exc:
        msg = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
        raise ValueError(f"boosted model file {str(path)!r} is not {expect}: OpenCV says {msg}") from None
    if not ok:
        raise ValueError(f"boosted model file {str(path)!r} is not {expect}")
    return boost


def boost_scores(model: Any, X: NDArray[np.float32]) -> NDArray[np.float64]:
    """Raw boosted scores ``(n,)`` of the float32 feature rows ``X`` ``(n, F)``: by the trees' walk of
    :mod:`pfpeople.detect.boost_trees` when ``model`` is a :class:`~pfpeople.detect.boost_trees.BoostTrees`, else by
    the OpenCV Boost ``model``'s ``predict`` (:func:`pfpeople.detect.training.boost_scores`): the same floats."""
    if isinstance(model, BoostTrees):
        return model.scores(X)
    return _opencv_scores(model, X)


#: The latest (scan, model key, legs) of :meth:`BoostedSegmentDetector._legs`.
_LATEST_LEGS: tuple[LaserScan, tuple[Any, ...], tuple[NDArray[np.float64], NDArray[np.float64]]] | None = None
#: The latest (scan, model and pairing key, (people, single legs)) of
#: :meth:`BoostedSegmentDetector.detect_with_singles`: the single-legs detector asks for them again.
_LATEST_PEOPLE: tuple[LaserScan, tuple[Any, ...], tuple[NDArray[np.float64], NDArray[np.float64]]] | None = None


class BoostedSegmentDetector:
    """Laser detector 2: segments classified as legs by a boosted classifier, paired into people.

    Parameters
    ----------
    model_path : str or Path, optional
        An OpenCV Boost model saved by :func:`pfpeople.detect.training.train_from_directory`; its JSON
        sidecar (same name, ``.json``) is read when present and must list the same features and segmentation.
        Default: the shipped model.
    threshold : float
        Score above which a segment is a leg (0 = the classifier's decision).
    pairing : PairingParams, optional
        How legs become people (shared with :class:`~pfpeople.detect.legs.LegDetector`).
    model : DetectorModel, optional
        PPV / FNR and field of view for the grid; default the values measured on the labelled data
        (:data:`gridbridge.params.CALIBRATED_LASER_DETECTORS`), 180 deg.
    """

    def __init__(
        self,
        model_path: str | Path | None = None,
        *,
        threshold: float = 0.0,
        pairing: PairingParams | None = None,
        model: DetectorModel | None = None,
    ) -> None:
        if model_path is not None and not isinstance(model_path, str | Path):
            raise TypeError(f"model_path must be a path, got {model_path!r} ({type(model_path).__name__})")
        path = Path(model_path) if model_path is not None else default_model_path()
        if not path.is_file():
            raise FileNotFoundError(f"boosted model file not found: {path}")
        threshold = check_number(threshold, "threshold")
        self.model_path = path
        self.threshold = float(threshold)
        self.pairing = pairing if pairing is not None else PairingParams()
        self.model = model if model is not None else CALIBRATED_LASER_DETECTORS[1]
        self.segmentation = SegmentationParams()
        self.sidecar: dict[str, object] = {}
        side = path.with_suffix(".json")
        if side.is_file():
            try:
                self.sidecar = json.loads(side.read_text())
            except (UnicodeDecodeError, json.JSONDecodeError) as exc:
                raise ValueError(f"boosted model sidecar {str(side)!r} is not valid JSON: {exc}") from None
            if not isinstance(self.sidecar, dict):
                raise ValueError(f"boosted model sidecar {str(side)!r} must hold a JSON object")
            feats = self.sidecar.get("features")
            if feats is not None and tuple(feats) != FEATURE_NAMES:  # type: ignore[arg-type]
                raise ValueError(f"{side}: features {feats} differ from this version's {list(FEATURE_NAMES)}")
            seg = self.sidecar.get("segmentation")
            if isinstance(seg, dict):
                self.segmentation = SegmentationParams(**seg)
        self._boost = _load_boost(path)
        check_model_values(path)
        self._trees: BoostTrees | None = load_trees(path, self._boost, len(FEATURE_NAMES))

    def _resolved_path(self) -> Path:
        """``self.model_path.resolve()``, resolved once per path (a file system call per scan otherwise)."""
        cached = getattr(self, "_resolved", None)
        if cached is None or cached[0] != self.model_path:
            cached = self._resolved = (self.model_path, self.model_path.resolve())
        return cached[1]

    def segment_scores(self, scan: LaserScan) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Centroids ``(S, 2)`` (m, scan frame) and boosted scores ``(S,)`` of every segment of ``scan``."""
        feats, centroids, _ = scan_features(scan, segmentation=self.segmentation)
        return centroids, self._scores(feats)

    def _scores(self, feats: NDArray[np.float64]) -> NDArray[np.float64]:
        """The raw boosted scores ``(S,)`` of the feature rows ``feats`` ``(S, F)`` (rounded to float32 first): the
        model's trees walked by :mod:`pfpeople.detect.boost_trees` when they reproduce OpenCV's scores (checked at
        load), else OpenCV's ``predict`` (:func:`pfpeople.detect.training.boost_scores`)."""
        return boost_scores(self._boost if self._trees is None else self._trees, feats.astype(np.float32))

    def _legs(self, scan: LaserScan) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Centroids ``(K, 2)`` and widths ``(K,)`` of the segments classified as legs; the latest result is kept
        by the scan's identity and the model, so the boosted and the single-legs detector of one laser classify
        each scan once."""
        global _LATEST_LEGS
        key = (self._resolved_path(), self.threshold, self.segmentation)
        latest = _LATEST_LEGS
        if latest is not None and latest[0] is scan and latest[1] == key:
            return latest[2]
        feats, centroids, widths = scan_features(scan, segmentation=self.segmentation)
        keep = self._scores(feats) > self.threshold
        _LATEST_LEGS = (scan, key, (centroids[keep], widths[keep]))
        return _LATEST_LEGS[2]

    def detect_legs(self, scan: LaserScan) -> NDArray[np.float64]:
        """Positions ``(K, 2)`` of segments classified as legs (centroids, m, scan frame)."""
        return self._legs(scan)[0]

    def detect(self, scan: LaserScan) -> NDArray[np.float64]:
        """Person positions ``(M, 2)`` (m, scan frame); ``(0, 2)`` for an empty or all-invalid scan."""
        return self.detect_with_singles(scan)[0]

    def detect_with_singles(self, scan: LaserScan) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """Person positions ``(M, 2)`` and unpaired single legs ``(S, 2)`` (m, scan frame)
        (:func:`pfpeople.detect.legs.people_and_single_legs`); the latest result is kept by the scan's identity,
        the model and the pairing (the arrays are shared: do not change them)."""
        global _LATEST_PEOPLE
        key = (self._resolved_path(), self.threshold, self.segmentation, self.pairing)
        latest = _LATEST_PEOPLE
        if latest is not None and latest[0] is scan and latest[1] == key:
            return latest[2]
        legs, widths = self._legs(scan)
        out = people_and_single_legs(legs, widths, params=self.pairing)
        for arr in out:
            arr.flags.writeable = False
        _LATEST_PEOPLE = (scan, key, out)
        return out
