"""Agents that learn to write: Stable-Baselines3 training, baselines and evaluation.

- :mod:`bathprint.agents.train`: ``bathprint train`` (PPO, SAC; checkpoints, resume,
  TensorBoard, held-out evaluation, training curve);
- :mod:`bathprint.agents.policies`: the baselines (random, best constant, scaling-law
  feedforward) and :func:`~bathprint.agents.policies.load_policy`;
- :mod:`bathprint.agents.fit`: ``bathprint baselines fit``;
- :mod:`bathprint.agents.evaluate`: ``bathprint evaluate``;
- :mod:`bathprint.agents.signals`, :mod:`bathprint.agents.vecenv`: SIGINT and SIGTERM
  handled alike (a checkpoint, then exit 130 / 143), vector-env workers that leave ending
  to their parent.

Hyperparameters live in the repository's ``agents/*.yml``
(:mod:`bathprint.agents.hyperparams`).
"""
