"""The particle filter's updater (phases 3-5): eq. 12 per cell with a detection likelihood, the particles scaled to
the posterior, births in empty cells, and the resampling when it is due.

The likelihoods are the grid filter's (one copy for both filters, :mod:`gridbridge.likelihoods`):
:class:`DeMorganLikelihood` (the paper's fusion, eqs. 13-14) and :class:`IndependentLikelihood` (calibrated,
conditionally independent detectors); a likelihood of your own follows :class:`DetectionLikelihood`.
"""

from gridbridge.likelihoods import DeMorganLikelihood, DetectionLikelihood, IndependentLikelihood
from pfpeople.particle.updater.update import CompiledUpdater, ReferenceUpdater, Updated

__all__ = [
    "CompiledUpdater",
    "DeMorganLikelihood",
    "DetectionLikelihood",
    "IndependentLikelihood",
    "ReferenceUpdater",
    "Updated",
]
