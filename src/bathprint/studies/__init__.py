"""Studies that run the simulator many times: sweeps, the paper's figures, the
work-precision study."""
