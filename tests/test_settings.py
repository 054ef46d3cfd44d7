"""The frame settings resolved in one place (issue 40 item 2): a setting given wins, else the
scene's own default, else the framework's declaration; the defaults below are typed here as
docs/command-line.md states them, not read from the code."""

from es2particles.frame.settings import Bloom, FrameSettings, resolve
from es2particles.run import resolved_settings
from es2particles.scenes.dejong import DeJong
from es2particles.scenes.fountain import Fountain
from es2particles.scenes.sph import Sph


def test_given_then_the_scenes_then_the_frameworks():
    scene = Sph(dimensions=3, spacing=0.1)
    assert resolve(FrameSettings(point_size=5.0), scene.defaults, "point_size") == 5.0
    assert resolve(FrameSettings(), scene.defaults, "point_size") == 20.0  # 200 x the spacing
    assert resolve(FrameSettings(), Sph().defaults, "point_size") == 2.0
    assert resolve(FrameSettings(), scene.defaults, "seed") == 0
    assert resolve(FrameSettings(), None, "exposure") == 4.0
    assert resolve(FrameSettings(), None, "intensity") == 1.0
    assert resolve(FrameSettings(), None, "size") == "1024x1024"
    assert resolve(FrameSettings(bloom=None), None, "bloom", DeJong().rendering()) is None
    bloom = resolve(FrameSettings(), None, "bloom", DeJong().rendering())
    assert (bloom.threshold, bloom.radius, bloom.intensity) == (0.2, 3.0, 0.8)
    assert Bloom() == bloom
    # Bloom is over any rendering's picture, off by default where it is not the density's.
    sprites = Fountain().rendering()
    assert resolve(FrameSettings(), None, "bloom", sprites) is None
    assert resolve(FrameSettings(bloom=Bloom(0.5)), None, "bloom", sprites) == Bloom(0.5)


def test_a_run_file_writes_what_the_plan_takes():
    """The run file's [settings] are the resolver's values: dejong's defaults, a given one."""
    written = resolved_settings(FrameSettings(exposure=2.5), DeJong())
    assert written["exposure"] == 2.5 and written["intensity"] == 1.0
    assert written["bloom"] == {"threshold": 0.2, "radius": 3.0, "intensity": 0.8}
    assert written["size"] == "1024x1024" and written["seed"] == 0
    assert written["particles"] == 2 ** 20
    assert resolved_settings(FrameSettings(), Fountain())["bloom"] is False
