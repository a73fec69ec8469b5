"""The particle filter, by job: its loop (:mod:`.filter`), the predictor (:mod:`.predictor`: people motion, ego
motion, births at the border), the updater (:mod:`.updater`: eq. 12 per cell with the shared likelihoods) and the
resampler (:mod:`.resampler`); :mod:`.forms` picks each model's reference or compiled form once per filter."""
