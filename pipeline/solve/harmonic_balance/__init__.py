"""The harmonic balance: residual, condensation onto the contact DOFs, the dynamic stiffness, operators for stability."""
