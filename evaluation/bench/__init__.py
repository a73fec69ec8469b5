"""Speed benchmarks (``python -m evaluation.bench.NAME``), each against the previous release in the same run."""
