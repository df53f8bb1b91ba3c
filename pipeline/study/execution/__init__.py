"""Running studies: cases, workers, checkpoints, searches, cost estimates."""
