"""pfpeople: particle-filter people-detector fusion into a local semantic grid, and what a robot user imports."""
