"""erosim: particle-based terrain erosion and flood simulation."""

__version__ = "0.1.0"
