"""Stability of periodic solutions: Hill's method, Floquet multipliers of the exact flow, along the HBM orbit, decided along a branch."""
