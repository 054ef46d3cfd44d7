"""numpy twins of the GLSL: each function has the name and the float32 arithmetic of its GLSL
peer, so the two read side by side, the bytes a GPU writes can be predicted, and tests have an
independent reference.

- ``pack.py``: ``lib/pack.glsl`` and ``lib/state.glsl`` (packing, state codecs); uploads and
  downloads use it too.
- ``life.py``: ``lib/life.glsl`` and ``lib/hash.glsl`` (the particle life cycle: age, emission,
  fade, staggered births), shared by the scenes that emit particles.
- ``drag.py``: ``lib/drag.glsl`` (linear drag integrated exactly), shared by the scenes' steps.
- ``particle.py``: ``lib/particle.glsl`` (the collision scene's step, in float64).
- The attractor maps sit with their scenes, one function beside each member
  (``scenes/dejong.py``: ``dejong_map``, ``scenes/clifford.py``: ``clifford_map``): a member is
  its map in GLSL and in numpy.
"""
