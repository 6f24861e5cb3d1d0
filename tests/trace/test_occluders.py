"""The shadow BVHs' split of a scene's triangles (``trace/occluders.py``): opaque
surfaces in the any-hit BVH, transmissive and cut-out ones in the walked one, emitters
in neither; and the tracer variant walks only where something lets light through."""

from __future__ import annotations

import dataclasses

import numpy as np
from trace_kit import emissive, grid_quad

from warp_hybrid.core.features import analyse_features
from warp_hybrid.scene.authoring.builders import make_scene, quad
from warp_hybrid.scene.device import DeviceScene
from warp_hybrid.scene.device.wide_bvh import WideBVHGPU
from warp_hybrid.scene.model import Material
from warp_hybrid.trace import TraceVariant
from warp_hybrid.trace.occluders import Occluders


def _scene(with_glass: bool):
    """Three quads (two triangles each): an opaque floor, an emitter and, with
    ``with_glass``, a glass pane (else a second opaque quad)."""
    mats = [
        Material("/floor"),
        emissive("/lamp", (5.0, 5.0, 5.0)),
        Material("/pane", opacity=0.2) if with_glass else Material("/card"),
    ]
    meshes = [
        quad((-1.0, 0.0, 1.0), (2.0, 0.0, 0.0), (0.0, 0.0, -2.0), 0),
        quad((-0.5, 3.0, 0.5), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0), 1),
        quad((-1.0, 1.0, 1.0), (2.0, 0.0, 0.0), (0.0, 0.0, -2.0), 2),
    ]
    return make_scene(meshes, mats)


def test_emitters_are_in_neither_shadow_bvh(device: str) -> None:
    """The glass pane's two triangles are walked, the floor's two blocked by any-hit, the
    emitter's two are in neither BVH."""
    ds = DeviceScene(_scene(with_glass=True), device)
    occ = Occluders(ds)
    lamp = set(np.flatnonzero(np.asarray(ds.scene.triangle_material) == 1).tolist())
    pane = np.flatnonzero(np.asarray(ds.scene.triangle_material) == 2)
    assert occ.special_count == 2
    assert occ.special_faces.numpy().tolist() == pane.tolist()
    assert not lamp & set(occ.special_faces.numpy().tolist())
    assert int(occ.gpu.opaque) != ds.mesh.id and occ.opaque_count == 2


def test_an_emitter_alone_needs_no_shadow_walk(device: str) -> None:
    """Opaque surfaces and an emitter: no walked BVH, and the variant's shadows are the
    any-hit query alone."""
    scene = _scene(with_glass=False)
    ds = DeviceScene(scene, device)
    occ = Occluders(ds)
    assert occ.special_count == 0 and int(occ.gpu.special) == 0
    assert occ.opaque_count == 4 and int(occ.gpu.opaque) != ds.mesh.id
    features = analyse_features(scene)
    assert features.emission
    assert not TraceVariant.for_scene(features, 1).layered_shadows


def _tree_bits(tree: WideBVHGPU) -> list[np.ndarray]:
    """A 4-wide copy's boxes and corners as bits (a node's child lanes are int32s)."""
    return [tree.node_data.numpy().view(np.int32), tree.corners.numpy().view(np.int32)]


def test_refits_of_moved_points_match_whole_refits() -> None:
    """CPU (the 4-wide copies): moves of a few floor points, of the glass pane, and two
    updates before one refresh.  After each refresh the scene's copy and the two shadow
    copies, refitted where the points moved, hold bit for bit what a whole refit of the
    same trees holds (a second device scene whose updates refit everything)."""
    mats = [Material("/floor"), emissive("/lamp", (5.0, 5.0, 5.0)), Material("/pane", opacity=0.2)]
    meshes = [
        grid_quad((-2.0, 0.0, 2.0), (4.0, 0.0, 0.0), (0.0, 0.0, -4.0), 12, 0),
        quad((-0.5, 3.0, 0.5), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0), 1),
        grid_quad((-1.0, 1.0, 1.0), (2.0, 0.0, 0.0), (0.0, 0.0, -2.0), 6, 2),
    ]
    scene = make_scene(meshes, mats)
    partial, whole = (DeviceScene(scene, "cpu") for _ in range(2))
    occluders = [Occluders(ds, wide=True) for ds in (partial, whole)]
    assert occluders[0].special_count > 0 and int(occluders[0].gpu.opaque) != partial.mesh.id
    floor = np.flatnonzero(np.abs(scene.points[:, 1]) < 1.0e-6)
    pane = np.flatnonzero(np.abs(scene.points[:, 1] - 1.0) < 1.0e-6)
    rng = np.random.default_rng(4)
    points = scene.points.copy()
    for moves in ([floor[:5]], [pane, floor[40:44]], [floor[100:101]]):
        for moved in moves:  # the updates before this refresh
            points = points.copy()
            points[moved] += rng.normal(0.0, 0.2, (len(moved), 3)).astype(np.float32)
            for ds in (partial, whole):
                ds.update(dataclasses.replace(scene, points=points))
            whole.moved_points = None  # its copies refit whole
            whole.wide_bvh.refit()
        for occ in occluders:
            occ.refresh()
        mine, theirs = occluders[0].gpu, occluders[1].gpu
        for name in ("scene_wide", "opaque_wide", "special_wide"):
            for a, b in zip(_tree_bits(getattr(mine, name)), _tree_bits(getattr(theirs, name))):
                assert np.array_equal(a, b), name
