"""Load the back end's compiled kernels before the first frame: the filter and the classifier, run on copies.

numba loads a kernel's machine code from its on-disk cache (or compiles it) at the first call with a new
signature, a few milliseconds each; a run's filter and classifier use a dozen to two dozen kernels, so without a
warm-up the first frames of a run wait for them (a latency a robot sees, and frame time a benchmark counts). The
front end's kernels have their own warm-ups (:func:`pfpeople.detect.segment_kernels.warm_up`,
:func:`pfpeople.perception.clutter_kernels.warm_up`).

:func:`warm_up_back_end` steps a deep copy of the filter three times (no odometry, standing, turning) with
one detection a metre ahead of each detector, and classifies each posterior with a copy of the classifier. The
copies are dropped: the run's filter, its random generator and its classifier are not touched, so every run file is the
same as without the warm-up (tests/pfpeople/pipeline/test_warm_up.py checks both).
"""

from __future__ import annotations

import copy
import logging
from collections.abc import Sequence
from typing import Any

import numpy as np

from gridbridge import jit
from gridbridge.classifiers import classify_frame
from gridbridge.ego_motion import Odometry
from gridbridge.geometry import Pose2D
from gridbridge.grid import GridSpec
from gridbridge.params import DetectorModel
from pfpeople.perception.odometry import FIRST_DT_S

__all__ = ["warm_up_back_end"]

log = logging.getLogger(__name__)

#: The warm-up steps' controls: no odometry, standing still, then driving and turning (each path of the
#: ego-motion prediction has its own kernels).
_CONTROLS = (None, Odometry(), Odometry(v=0.5, omega=0.3))
#: The warm-up steps' time step (s): the first frame's (its people-motion kernel is computed and cached now).
_DT = FIRST_DT_S


def warm_up_back_end(filt: Any, classifier: Any, spec: GridSpec, models: Sequence[DetectorModel]) -> bool:
    """Run copies of ``filt`` and ``classifier`` on three made-up frames so their compiled kernels load now.

    Parameters
    ----------
    filt : StepFilter
        The run's filter (grid or particle); it is copied, not stepped.
    classifier : Classifier or HysteresisPeaks
        The run's classifier; copied.
    spec : GridSpec
        The grid (grid frame, m).
    models : sequence of DetectorModel
        Per detector, its model (mount in the grid frame); each detector gets one detection 1 m ahead of its
        mount.

    Returns
    -------
    bool
        Whether the warm-up ran (False: no compiled kernels in use, a filter whose ``step`` is wrapped on the
        instance (a copy's wrapper would step the original), or one that could not be copied or stepped; each is
        logged and leaves the run as it is).
    """
    if not (jit.enabled("gridbridge") or jit.enabled("pfpeople")):
        return False
    if "step" in getattr(filt, "__dict__", {}):  # a wrapped step: its copy would call the original's
        log.debug("no warm-up: the filter's step is wrapped")
        return False
    try:
        f, c = copy.deepcopy(filt), copy.deepcopy(classifier)
    except Exception as exc:  # a caller's filter need not be copyable: its kernels then load in the first frame
        log.debug("no warm-up: the filter or classifier cannot be copied (%s: %s)", type(exc).__name__, exc)
        return False
    dets = [np.array([[m.mount_x + np.cos(m.mount_yaw), m.mount_y + np.sin(m.mount_yaw)]]) for m in models]
    try:
        for odometry in _CONTROLS:
            step = f.step(dets, odometry, _DT)
            belief = np.asarray(step.posterior, dtype=float)
            observed = np.asarray(step.covered).any(axis=0)
            classify_frame(c, belief, spec, observed=observed, ego=Pose2D())
    except Exception as exc:
        log.debug("warm-up step failed (%s: %s); the kernels load in the first frame", type(exc).__name__, exc)
        return False
    return True
