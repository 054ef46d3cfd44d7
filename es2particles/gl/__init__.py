"""The GL edge: the headless context and what it owns, shader loading, the generated interface of
a stage, and the one draw command every draw goes through. Nothing above this package talks to
moderngl."""
