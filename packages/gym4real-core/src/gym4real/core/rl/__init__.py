"""RL training for Gym4ReaL: tabular Q-learning/SARSA (numpy) and PPO/DQN (Stable-Baselines3, extra ``rl``)."""
