"""Reproductions of the paper's figures from the simulator (PNG + CSV each)."""
