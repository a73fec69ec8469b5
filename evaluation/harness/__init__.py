"""The evaluation harness: A/B evaluation, the benchmark, calibration, replay, tracking evaluation, sweeps and
figures."""
