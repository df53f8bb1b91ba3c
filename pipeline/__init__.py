"""Reduced-order study pipeline for shrouded bladed disks with dry friction.

Data flows one way: FE model -> reduction -> assembly with contact -> HBM ->
continuation -> study / dataset.  See README.md.
"""
__version__ = "0.1.0"
