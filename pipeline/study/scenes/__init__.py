"""The [scene] of a study file: lumped, lumped disk, FE blade and blade-wheel scenes, contact laws placed by the file."""
