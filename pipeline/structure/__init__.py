"""Finite-element blades (scikit-fem) and their Craig-Bampton reduction."""
