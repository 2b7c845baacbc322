"""Everything that builds, checks and measures the shipped model; never shipped in the extension.

Four folders, one job each, and who may import whom:

- ``simulation/``: the forward model as a renderer — the OSL shader and headless Cycles scene,
  the numpy renderer that mirrors it, basis cubes, spectral EXR files and synthetic photos
  (camera, exposure, noise, file encodings). Imports the core only.
- ``learning/``: the SPD prior (synthetic lamp spectra from physics), the training dataset
  (synthetic photos through the product's own inverse path), torch training, ONNX export and
  the tuning of the solve. Imports the core and ``simulation``.
- ``evaluation/``: how good the shipped model is — real lamps (the only code that reads the
  measured SPDs), benchmarks, render benchmarks, the model card. Imports everything above.
- ``reliability/``: hostile inputs, forward-model extremes and the soak — the catalogues the
  tests assert and ``make reliability`` reports. Imports the core and ``simulation``.

``cd_spectra_addon`` never imports anything from here.
"""
