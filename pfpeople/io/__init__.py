"""Input and output: bags (read, TF, sync, write, inspect), the run directory and its sinks, JSON, ground-truth
files and lock files."""
