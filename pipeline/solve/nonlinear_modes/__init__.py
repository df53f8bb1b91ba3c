"""Nonlinear modes: the extended periodic motion concept (`epmc`), its continuation in
the modal amplitude (`backbone`) and forced responses synthesised from it (`synthesis`)."""
