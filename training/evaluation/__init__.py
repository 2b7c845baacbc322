"""How good the product is: the measured lamps, the benchmarks, the model card.

``lamps`` is the only reader of the measured SPDs (LSPDD, colour-science's measured sources):
they are for evaluation, never for training or selection. ``evaluate`` writes
``bench/eval.md``, ``bench`` the error-vs-time benchmark, ``bench_render`` the renderer's,
``model_card`` ``models/MODEL_CARD.md``.

May import: the core, ``training.simulation`` and ``training.learning``. Nothing imports it but
its own command lines and the tests.
"""
