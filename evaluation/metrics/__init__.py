"""Metrics: people detection on the grid and belief scores, CLEAR-MOT, standing and walking recall."""
