"""Test support shared by the tests and ``make reliability``: what should not break the product.

``hostile`` is the catalogue of bad inputs (broken, huge, odd, dark, disc-less photos, broken
models and presets) and what each must produce; ``stress`` the forward model's extreme captures;
``soak`` the long-run memory check; ``report`` runs them all into ``bench/reliability.md``.

May import: the core and ``training.simulation``.
"""
