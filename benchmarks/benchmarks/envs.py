"""Environment steps per second (CoilRadius-v1, draft accuracy, random actions)."""

from __future__ import annotations

import time

import bathprint.envs as E

ENV = "bathprint/CoilRadius-v1"
POOL = 4  # training targets printed before the measurement (each one episode)


class EnvSteps:
    timeout = 900
    steps = 200

    def setup(self) -> None:
        kwargs = {"spec_overrides": {"target": {"train_pool": POOL}}}
        self.env = E.make(ENV, accuracy="draft", **kwargs)
        self.env.action_space.seed(0)
        self.env.reset(seed=0)
        for _ in range(20):  # compile, and print the pool's targets
            self._step()

    def _step(self) -> None:
        _, _, term, trunc, _ = self.env.step(self.env.action_space.sample())
        if term or trunc:
            self.env.reset()

    def track_steps_per_s(self) -> float:
        t0 = time.perf_counter()
        for _ in range(self.steps):
            self._step()
        return self.steps / (time.perf_counter() - t0)

    track_steps_per_s.unit = "steps/s"
