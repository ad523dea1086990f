"""Analyses on top of the simulator: the paper's theory, measurements of coils and
regimes, the analytic validation checks, stability limits and the lab's methods."""
