"""Friction in the contact plane: the 2D Coulomb slider with variable normal load
(`law`: `Friction2D`, `cycle_results`), its compiled march over one period (`kernel`,
also the 1D element's AFT) and the fully stuck slider at the centre of the stick discs
(`centre`)."""
