"""The built-in people detectors (Batista & Pereira 2015, Sect. 4): two laser detectors and one camera detector.

========================  ==========================================================  =====================
class                     method                                                      default model
========================  ==========================================================  =====================
:class:`LegDetector`      geometric leg candidates paired into people (Bellotto & Hu)  measured (1)
:class:`BoostedSegment    boosted segment classifier (Arras et al.; Spinello &         measured (1)
Detector`                 Siegwart), trained by ``pfpeople train-detector`` on the
                          six labelled leg_tracker bags and simulated scans
:class:`LearnedPeople    a learned whole-scan detector (DROW3 / DR-SPAAM style):       measured (2)
Detector`                 range-normalised cut-outs of every return -> a small
                          network -> votes for person centres; trained by
                          ``pfpeople train-detector --kind learned``, run with NumPy
:class:`MotionDetector`   returns where earlier scans saw free space, grouped into     measured (1)
                          person candidates (needs the ego-motion)
:class:`HogCameraDetec    OpenCV HOG + flat-ground range (Stein et al. 2003)           PPV 0.95, FNR 0.50
tor`                                                                                  (Table 1)
========================  ==========================================================  =====================

(1) PPV / FNR measured on the labelled data: :data:`gridbridge.params.CALIBRATED_LASER_DETECTORS`.
(2) measured on the leave-one-bag-out folds of its training, in its model card.

Each has ``detect(...) -> (M, 2)`` person positions (m) and a ``.model`` (:class:`gridbridge.DetectorModel`).
"""

from pfpeople.detect.boosted import BoostedSegmentDetector, default_model_path
from pfpeople.detect.camera import HogCameraDetector, HogParams, default_intrinsics, foot_points, horizon_row
from pfpeople.detect.learned.detector import LearnedPeopleDetector, default_learned_model_path
from pfpeople.detect.legs import (
    LegDetector,
    LegDetectorParams,
    PairingParams,
    pair_legs,
    people_and_single_legs,
    people_from_legs,
)
from pfpeople.detect.motion import MotionDetector, MotionParams
from pfpeople.detect.segments import (
    FEATURE_NAMES,
    SegmentationParams,
    Segments,
    segment_features,
    segment_scan,
)
from pfpeople.detect.single_legs import SingleLegDetector

__all__ = [
    "FEATURE_NAMES",
    "BoostedSegmentDetector",
    "HogCameraDetector",
    "HogParams",
    "LearnedPeopleDetector",
    "LegDetector",
    "LegDetectorParams",
    "MotionDetector",
    "MotionParams",
    "PairingParams",
    "SegmentationParams",
    "Segments",
    "SingleLegDetector",
    "default_intrinsics",
    "default_learned_model_path",
    "default_model_path",
    "foot_points",
    "horizon_row",
    "pair_legs",
    "people_and_single_legs",
    "people_from_legs",
    "segment_features",
    "segment_scan",
]
