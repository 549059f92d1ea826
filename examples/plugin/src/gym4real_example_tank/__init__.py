"""Example gym4real plugin: keep the level of a tank at its target (``gym4real/tank-v0``)."""
