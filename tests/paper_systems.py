"""The paper's examples for the tests (see pipeline/paper_systems.py)."""
from pipeline.paper_systems import example1, example2, example3  # noqa: F401
