"""hoi_tutorial: NIFTY, SAMP and CHOICE rebuilt at reduced scale on a procedural toy world.

Sub-packages: ``world`` (the toy world), ``nn`` (neural building blocks), ``metrics``,
``viz`` (plots, renders, animations), ``infra`` (presets, seeding, cache, training loop),
``ledger`` (the papers' claims and what the chapters computed for them), and one package per paper.
"""
# PEP 440: X.Y.Z for a release, X.Y.Z.devN for the code after the last release (scripts/release.py sets both this and
# pyproject.toml's version; tests/test_release.py checks them against CHANGELOG.md and CITATION.cff).
__version__ = "0.2.0.dev0"
