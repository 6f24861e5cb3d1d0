"""``scene_info`` / ``format_info``: the data behind ``warp-hybrid info``."""

from __future__ import annotations

import json

import numpy as np
from pxr import UsdLux
from usd_stage_kit import bind, new_stage, preview_material, unit_quad

from warp_hybrid.scene.authoring.builders import look_at_camera, make_scene, quad
from warp_hybrid.scene.model import Environment, Light, LightKind, Material
from warp_hybrid.scene.usd.info import format_info, scene_info
from warp_hybrid.scene.usd.loader import UsdSceneSource


def test_scene_info_of_built_scene():
    scene = make_scene(
        [
            quad((0, 0, 0), (2, 0, 0), (0, 3, 0), material=0, name="/Q"),
            quad((0, 0, 1), (1, 0, 0), (0, 1, 0), material=1, name="/G"),
        ],
        [Material("matte"), Material("glass", opacity=0.0, ior=1.5)],
        lights=[Light(LightKind.SPHERE, "/Lamp", (1.0, 1.0, 1.0))],
        cameras=[look_at_camera((0, 0, 5), (0, 0, 0), name="/Cam")],
        environment=Environment("/Sky", (0.1, 0.1, 0.1)),
        path="built.usda",
        time_range=(0.0, 10.0),
        warnings=["/X: something"],
    )
    info = scene_info(scene)
    assert json.loads(json.dumps(info)) == info
    assert (info["triangles"], info["points"], info["meshes"], info["materials"]) == (4, 8, 2, 2)
    assert info["lights"] == [{"kind": "sphere", "name": "/Lamp"}, {"kind": "dome", "name": "/Sky"}]
    assert info["cameras"] == ["/Cam"]
    assert info["time_range"] == [0.0, 10.0]
    assert info["effects"] == ["shadows", "reflections", "refractions", "transparency", "environment"]
    np.testing.assert_allclose(info["bounds"], [[0, 0, 0], [2, 3, 1]])
    text = format_info(info)
    assert "triangles   4 (8 points)" in text
    assert "sphere   /Lamp" in text and "dome     /Sky" in text
    assert "time range  0 .. 10 at 24 codes/s" in text
    assert "effects     shadows, reflections, refractions, transparency, environment" in text
    assert "warnings    1\n    /X: something" in text


def test_scene_info_of_usd_source_lists_layers(tmp_path):
    stage, path = new_stage(tmp_path)
    mat, _ = preview_material(stage, "/World/Looks/Glow", emissiveColor=(1.0, 1.0, 1.0))
    bind(unit_quad(stage, "/World/Q"), mat)
    UsdLux.DistantLight.Define(stage, "/World/Sun")
    stage.GetRootLayer().Save()
    source = UsdSceneSource(path)
    info = scene_info(source.scene_at(), source)
    assert info["layers"] == [str(path)]
    assert info["lights"] == [{"kind": "distant", "name": "/World/Sun"}]
    assert info["time_range"] is None
    assert "emission" in info["effects"]
    assert "time range  none (static)" in format_info(info)
