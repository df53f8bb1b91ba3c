"""Figures of study results (matplotlib)."""
