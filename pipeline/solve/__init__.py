"""Solvers on a System: HBM residual, continuation, stability, response curves,
resonances, linear response and event-driven time integration."""
