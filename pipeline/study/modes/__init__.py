"""Modal studies: blade modal convergence, frequency vs nodal diameter."""
