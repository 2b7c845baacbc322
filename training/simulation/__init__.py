"""The forward model as a renderer: a CD photo of any spectrum, from Cycles or numpy.

``shaders/cd_grating.osl`` and ``cycles_scene`` render the grating BRDF of
:mod:`cd_spectra_addon.core.scene.grating` in headless Cycles; ``render_numpy`` renders the same model
with numpy (the two are cross-checked by the tests); ``basis`` caches one radiance image per
5 nm band (a basis cube) per capture, ``spectral_exr`` stores cubes, ``photo`` turns a cube and an
SPD into a camera file (sensor, exposure, noise, encoding). ``render_photo``, ``render_basis`` and
``render_cubes`` are the command lines.

May import: ``cd_spectra_addon.core``. Imported by: learning, evaluation, reliability, tests.
"""
