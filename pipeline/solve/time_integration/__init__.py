"""Event-driven time integration of the piecewise-linear contact flow: the independent reference, and shooting."""
