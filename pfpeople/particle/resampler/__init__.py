"""The particle filter's resampler: when (:class:`Resampling`'s effective sample size and overflow) and how (the
schemes of :mod:`.schemes`, by cell in :mod:`.by_cell`) the particles are resampled."""

from pfpeople.particle.resampler.by_cell import resample_by_cell
from pfpeople.particle.resampler.policy import Resampler, Resampling
from pfpeople.particle.resampler.schemes import RESAMPLERS, effective_sample_size, get_resampler

__all__ = ["RESAMPLERS", "Resampler", "Resampling", "effective_sample_size", "get_resampler", "resample_by_cell"]
