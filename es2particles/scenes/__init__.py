"""Scenes: each module describes one simulation (its quantities, passes, start and view).

``SCENES`` maps a scene's command-line name to its class.
"""

from .collision import Collision
from .dejong import DeJong

SCENES = {DeJong.name: DeJong, Collision.name: Collision}
