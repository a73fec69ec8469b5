"""The particle filter: particle state, the sampling forms of the motion models, resampling, the filter and
its compiled step."""
