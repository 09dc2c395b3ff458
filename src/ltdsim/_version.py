"""ltdsim's version, read by the package's face, its caches' keys and its reports."""

__version__ = "0.1.0"
