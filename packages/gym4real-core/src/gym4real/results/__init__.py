"""Publishing: ``reproduce`` (plan, runner, storage, Ray), provenance, analysis, claims and the results page.

Also the currency of published sections (fingerprints, ``reproduce --check``). Imports
:mod:`gym4real.core`, :mod:`gym4real.bench` and :mod:`gym4real.rl`.
"""
