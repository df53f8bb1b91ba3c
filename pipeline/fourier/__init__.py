"""The Fourier layout of the harmonic balance (paper Eq. 2-3) and certified sign changes
of trigonometric polynomials.  Imports nothing else of the package."""
