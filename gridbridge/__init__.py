"""gridbridge: the local semantic grid and the reference grid filter of Batista & Pereira (2015).

Public names other packages and outside tools rely on: :class:`GridSpec`, :class:`GridFilter`,
:func:`people_motion_kernel`, :func:`predict_people`, :func:`fuse_detectors`, :func:`bayes_update`.
"""

from gridbridge.blobs import Blob, BlobParams, ClassificationResult, classify_blobs, classify_threshold
from gridbridge.ego_motion import (
    Odometry,
    ego_motion_sigma_points,
    predict_sensor,
    velocity_displacement,
    warp_belief,
)
from gridbridge.filter import BeliefFilter, FilterStep, GridFilter, Prediction, as_odometry
from gridbridge.geometry import Pose2D
from gridbridge.grid import GridSpec
from gridbridge.measurement import (
    Likelihood,
    bayes_update,
    detection_map,
    detector_likelihood,
    fov_mask,
    fuse_detectors,
    likelihood_from_detections,
    rasterise,
)
from gridbridge.params import PAPER_DETECTORS, DetectorModel, PeopleMotion, SensorMotionNoise
from gridbridge.people_motion import people_motion_kernel, predict_people, truncated_speed_pdf

__all__ = [
    "PAPER_DETECTORS",
    "BeliefFilter",
    "Blob",
    "BlobParams",
    "ClassificationResult",
    "DetectorModel",
    "FilterStep",
    "GridFilter",
    "GridSpec",
    "Likelihood",
    "Odometry",
    "PeopleMotion",
    "Pose2D",
    "Prediction",
    "SensorMotionNoise",
    "as_odometry",
    "bayes_update",
    "classify_blobs",
    "classify_threshold",
    "detection_map",
    "detector_likelihood",
    "ego_motion_sigma_points",
    "fov_mask",
    "fuse_detectors",
    "likelihood_from_detections",
    "people_motion_kernel",
    "predict_people",
    "predict_sensor",
    "rasterise",
    "truncated_speed_pdf",
    "velocity_displacement",
    "warp_belief",
]
