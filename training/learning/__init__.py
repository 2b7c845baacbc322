"""The learned stage: synthetic spectra, training data, the network and the solve's tuning.

``spd_prior`` draws lamp spectra from physical families (never from measured lamps);
``dataset`` renders them into synthetic photos and reads each back through the product's one
inverse path (:func:`cd_spectra_addon.core.inverse.stages.read_photo`); ``train`` fits the network and
exports ONNX; ``tune_solver`` and ``tune_fusion`` choose the physics solve's regularisation and
how far the final solve trusts the network — on synthetic photos only.

May import: ``cd_spectra_addon.core`` and ``training.simulation``. Never the measured lamps.
"""
