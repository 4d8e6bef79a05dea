"""The package version (kept in the lowest layer, so every layer may record it)."""

__version__ = "0.1.0"
