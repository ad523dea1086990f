"""The simulator: a scene compiled into a model, the state of the rod, the effects that
act on it, the solver and the time stepper that moves it."""
