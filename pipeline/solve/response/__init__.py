"""Frequency-response curves: continuation of the harmonic balance over frequency, the linear response, resonance guard, optimum preload."""
