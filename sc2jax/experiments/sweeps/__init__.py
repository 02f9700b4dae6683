"""Hyper-parameter sweeps (runs trained together), the paper's random search and Table 1."""
