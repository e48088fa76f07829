"""The version of vibeam (also ``vibeam.__version__``; pyproject.toml holds the same)."""
__version__ = "0.1.0"
