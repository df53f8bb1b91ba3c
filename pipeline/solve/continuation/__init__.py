"""Arc-length continuation of a residual R(x, lam) = 0: predictor, Newton corrector, step control, branch refinement."""
