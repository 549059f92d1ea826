"""Integrations of Gym4ReaL with distributed RL engines (each an optional extra of core)."""
