"""hoi_tutorial: NIFTY, SAMP and CHOICE rebuilt at reduced scale on a procedural toy world.

Sub-packages: ``world`` (the toy world), ``nn`` (neural building blocks), ``metrics``,
``viz`` (plots, renders, animations), ``infra`` (presets, seeding, cache, training loop),
``ledger`` (the papers' claims and what the chapters computed for them), and one package per paper.
"""
__version__ = "0.1.0"
