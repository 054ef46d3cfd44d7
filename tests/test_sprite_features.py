"""The sprites' features as declarations of their own (render/sprites.py, sort.py, shadow.py,
lamp.py, buffer.py, shafts.py): each takes its own declaration, checks what it needs of the
sprites, plans its own stages, and its options come from its own parameters. No GL: plans made
against stated capabilities."""

import pytest

from es2particles.errors import CapabilityError, ParameterError
from es2particles.frame.plan import plan_frame
from es2particles.frame.settings import FrameSettings
from es2particles.gl.context import Capabilities
from es2particles.render.buffer import BufferParams, SoftParams, SoftParticles, SpriteBuffer
from es2particles.render.lamp import Lamp
from es2particles.render.shadow import OpacityShadow
from es2particles.render.shafts import ShaftParams
from es2particles.render.sort import DepthSort, SortParams
from es2particles.render.sprites import SpriteLook, Sprites
from es2particles.scenes import Collision3D, Fountain, Smoke

SHADOW = OpacityShadow(light=(-3.0, 8.0, 3.0), centre=(0.0, 2.4, 0.0), radius=3.6)
LAMP = Lamp(position=(1.6, 5.5, 1.2), target=(0.0, 0.0, 0.0))


def plan(scene, **caps):
    return plan_frame(scene, FrameSettings(particles=256, size=(64, 48)),
                      Capabilities.assumed(**caps))


@pytest.mark.parametrize("slot, value, kind", [
    ("sort", "full", "DepthSort"), ("shadow", 1.0, "OpacityShadow"), ("lamp", (0, 5, 0), "Lamp"),
    ("soft", 0.2, "SoftParticles"), ("buffer", 0.5, "SpriteBuffer")])
def test_a_feature_is_given_by_its_own_declaration_or_refused_naming_it(slot, value, kind):
    with pytest.raises(ParameterError, match=f"sprites' {slot} must be a {kind} or None, got"):
        Sprites(**{slot: value})


def test_each_feature_checks_what_it_needs_of_the_sprites():
    with pytest.raises(ParameterError, match=r"shadow needs attenuation \(0, 0, c\)"):
        Sprites(shadow=SHADOW, attenuation=(1.0, 0.0, 0.0))
    with pytest.raises(ParameterError, match="shadow needs a fade role"):
        Sprites(shadow=SHADOW, roles={"position": "position"})
    with pytest.raises(ParameterError, match="jogl size law gives every sprite one size"):
        Sprites(shadow=SHADOW, size_law="jogl")
    with pytest.raises(ParameterError, match="one kind of shadow at a time"):
        Sprites(shadow=SHADOW, lamp=LAMP)
    with pytest.raises(ParameterError, match="the lamp's shadows need sprites of a world size"):
        Sprites(lamp=LAMP, size_law="jogl")
    with pytest.raises(ParameterError, match=r"merge passes per frame.*\[1, 1000000\]"):
        DepthSort(0)
    with pytest.raises(ParameterError, match="buffer scale must be in"):
        SpriteBuffer(0.0)
    with pytest.raises(ParameterError, match="upsample must be one of"):
        SpriteBuffer(0.5, "cubic")
    with pytest.raises(ParameterError, match="scene depth must be one of"):
        SoftParticles(0.1, "z")


def test_the_look_s_options_are_its_own_and_its_features():
    own = {"blend", "sprite", "size_law"}
    features = [SoftParams, BufferParams, ShaftParams]
    names = set(SpriteLook.options())
    parts = [set(f.options()) for f in features]
    assert names == own.union(*parts)
    assert not set.intersection(*parts)  # no option declared twice
    assert set(SortParams.options()) == {"sort"} <= set(Smoke.Params.options())
    assert "sort" not in Fountain.Params.options()  # its sprites take no sort


@pytest.mark.parametrize("text, passes", [("full", None), ("off", "none"), ("7", 7)])
def test_the_sort_option_asks_for_its_feature(text, passes):
    got = Smoke(sort=text).rendering().sort
    assert (got is None) if passes == "none" else got == DepthSort(passes)


def test_each_feature_plans_its_own_stages_and_says_so_when_off():
    every = plan(Smoke(sort="3", shadows="on", soft=0.1, buffer_scale=0.5, shafts="on"))
    names = [s.name for s in every.stages]
    for stage in ("sort key", "sort merge", "shadow map", "sprites", "upsample", "shafts"):
        assert any(n == stage or n.startswith(stage + " ") for n in names), (stage, names)
    assert every.stages[names.index("sprites")].target.resource == "sprite buffer"
    off = {"depth sort (switched off: texel order)", "shadow map (switched off)",
           "light shafts (switched off)"}
    assert not off & set(every.left_out)
    none = plan(Smoke(sort="off", shadows="off"))
    names = [s.name for s in none.stages]
    assert not any(n.startswith(("sort", "shadow", "upsample", "shafts")) for n in names)
    assert off <= set(none.left_out)
    lamp = plan(Collision3D(shadows="on", field_resolution=16))
    assert any(s.name.startswith("lamp ") for s in lamp.stages)


def test_without_vertex_fetch_each_feature_that_needs_it_names_itself():
    caps = dict(max_vertex_texture_units=0)
    with pytest.raises(CapabilityError, match="this context has no vertex texture units: the "
                                              "depth sort and the shadow map of this scene's"):
        plan(Smoke(), **caps)
    with pytest.raises(CapabilityError, match="units: the lamp and light shafts of this"):
        plan(Collision3D(shadows="on", shafts="on", field_resolution=16), **caps)
    plan(Fountain(soft=0.1, buffer_scale=0.5), **caps)  # the buffer needs no fetch
