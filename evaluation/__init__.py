"""pfpeople evaluation: scenarios with ground truth, metrics, A/B evaluation, benchmarks."""
