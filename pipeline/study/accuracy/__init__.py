"""Accuracy-versus-cost studies: what each accuracy setting buys."""
