"""The assembled mechanical system (M, C, K, contact maps, forcing) and its cyclic
disk assembly."""
