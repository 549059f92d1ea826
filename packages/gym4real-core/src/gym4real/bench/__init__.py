"""Measurement: test protocols and the benchmark harness, policy strings, statistics, the suite score.

Also the reference runs that ``evaluate`` scores against, the hindsight planners' shared parts (upper
references), multi-objective evaluation, figures and reports. Imports only :mod:`gym4real.core` (and the
wrappers); model files are read by loaders of :mod:`gym4real.rl` named in :mod:`gym4real.bench.policies`.
"""
