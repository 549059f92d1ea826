"""Training the paper's agents: ``train``, the Stable-Baselines3 and tabular trainers, presets, schedules.

Also batched evaluation for model selection, model files and learning curves. Imports :mod:`gym4real.core`
and :mod:`gym4real.bench`.
"""
