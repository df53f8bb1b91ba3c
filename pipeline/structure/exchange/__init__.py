"""Structures exchanged with other FE codes: their exported matrices, CalculiX decks."""
