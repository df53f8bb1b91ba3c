"""Study files: reading, validating and describing TOML studies."""
