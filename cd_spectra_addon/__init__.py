"""CD Spectra: a lamp's spectrum from one photo of a CD (Blender add-on + numpy core)."""

__version__ = "0.1.0"
