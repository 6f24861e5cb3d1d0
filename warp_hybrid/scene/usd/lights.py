"""UsdLux lights -> world-space ``Light`` entries and the dome ``Environment``.

Every light's ``color`` is inputs:color * intensity * 2**exposure, times
``UsdLux.BlackbodyTemperatureAsRgb(colorTemperature)`` (pxr's luminance-normalised
blackbody tint) when enableColorTemperature is on.  Geometry comes from the light's
local-to-world matrix at the time code: ``position`` is its origin, ``direction`` its
local -Z, a rect light's ``axis_u``/``axis_v`` its local X/Y scaled by half the
width/height, a disk's by its radius; sphere and disk radii scale with the transform.

DistantLight (angle), SphereLight (radius, treatAsPoint, ShapingAPI cone angle and
softness), RectLight, DiskLight and DomeLight (lat-long ``texture:file`` or constant
colour) are supported; the first DomeLight becomes ``Scene.environment`` (its
``world_to_light`` is the inverse of its world rotation, scale removed, then for a
DomeLight_1 whose pole is +Z the turn that puts that pole on +Y).  Other light
types, extra domes, light textures on rect lights, IES profiles and shaping focus are
reported once per prim.
"""

from __future__ import annotations

import numpy as np
from pxr import Sdf, Usd, UsdGeom, UsdLux

from ..model import Environment, Light, LightKind, Wrap
from .textures import ImageLibrary
from .validate import Diagnostics


def _get(prim: Usd.Prim, name: str, time: Usd.TimeCode, default: object) -> object:
    attr = prim.GetAttribute(name)
    value = attr.Get(time) if attr else None
    return default if value is None else value


def light_color(prim: Usd.Prim, time: Usd.TimeCode) -> tuple[float, float, float]:
    """inputs:color * intensity * 2**exposure (* blackbody tint when enabled)."""
    color = np.asarray(_get(prim, "inputs:color", time, (1.0, 1.0, 1.0)), dtype=np.float64)
    intensity = float(_get(prim, "inputs:intensity", time, 1.0))
    exposure = float(_get(prim, "inputs:exposure", time, 0.0))
    out = color * intensity * 2.0**exposure
    if bool(_get(prim, "inputs:enableColorTemperature", time, False)):
        kelvin = float(_get(prim, "inputs:colorTemperature", time, 6500.0))
        out = out * np.asarray(UsdLux.BlackbodyTemperatureAsRgb(kelvin), dtype=np.float64)
    return (float(out[0]), float(out[1]), float(out[2]))


def rotation_of(matrix: np.ndarray) -> np.ndarray:
    """The closest rotation (3x3, column-vector convention: ``v_world = R @ v_local``)
    to the linear part of a USD row-vector matrix, i.e. its scale and shear removed."""
    u, _s, vt = np.linalg.svd(np.asarray(matrix, dtype=np.float64)[:3, :3].T)
    return u @ vt


def _unit(v: np.ndarray) -> tuple[float, float, float]:
    n = np.linalg.norm(v)
    w = v / n if n > 0 else np.array([0.0, 0.0, -1.0])
    return (float(w[0]), float(w[1]), float(w[2]))


def _vec(v: np.ndarray) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))


def read_light(prim: Usd.Prim, time: Usd.TimeCode, matrix: np.ndarray, diag: Diagnostics) -> Light | None:
    """One non-dome light in world space (``matrix``: its USD row-vector
    local-to-world transform), or None (warned) for an unsupported type."""
    name = str(prim.GetPath())
    type_name = prim.GetTypeName()
    x, y, z, origin = matrix[0, :3], matrix[1, :3], matrix[2, :3], matrix[3, :3]
    common = dict(
        name=name,
        color=light_color(prim, time),
        position=_vec(origin),
        direction=_unit(-z),
        normalize=bool(_get(prim, "inputs:normalize", time, False)),
    )
    mean_scale = float(np.mean([np.linalg.norm(x), np.linalg.norm(y), np.linalg.norm(z)]))
    if prim.IsA(UsdLux.DistantLight):
        return Light(LightKind.DISTANT, angle_deg=float(_get(prim, "inputs:angle", time, 0.53)), **common)
    if prim.IsA(UsdLux.SphereLight):
        radius = float(_get(prim, "inputs:radius", time, 0.5)) * mean_scale
        if bool(_get(prim, "treatAsPoint", time, False)):
            radius = 0.0
        cone, softness = _shaping(prim, time, diag)
        return Light(LightKind.SPHERE, radius=radius, cone_angle_deg=cone, cone_softness=softness, **common)
    if prim.IsA(UsdLux.RectLight):
        if prim.GetAttribute("inputs:texture:file").HasAuthoredValue():
            diag.warn("RectLight texture:file is not supported; the light is uniform", name)
        half_w = 0.5 * float(_get(prim, "inputs:width", time, 1.0))
        half_h = 0.5 * float(_get(prim, "inputs:height", time, 1.0))
        cone, softness = _shaping(prim, time, diag)
        return Light(
            LightKind.RECT,
            axis_u=_vec(x * half_w),
            axis_v=_vec(y * half_h),
            cone_angle_deg=cone,
            cone_softness=softness,
            **common,
        )
    if prim.IsA(UsdLux.DiskLight):
        r = float(_get(prim, "inputs:radius", time, 0.5))
        cone, softness = _shaping(prim, time, diag)
        return Light(
            LightKind.DISK,
            axis_u=_vec(x * r),
            axis_v=_vec(y * r),
            radius=r * 0.5 * float(np.linalg.norm(x) + np.linalg.norm(y)),
            cone_angle_deg=cone,
            cone_softness=softness,
            **common,
        )
    diag.warn(f"light type {type_name or 'untyped'} is not supported; skipped", name)
    return None


def _shaping(prim: Usd.Prim, time: Usd.TimeCode, diag: Diagnostics) -> tuple[float, float]:
    """ShapingAPI cone (angle off the -Z axis in degrees, softness); 180 = no cone."""
    if not prim.HasAPI(UsdLux.ShapingAPI) and not prim.GetAttribute("inputs:shaping:cone:angle").HasAuthoredValue():
        return 180.0, 0.0
    name = str(prim.GetPath())
    for attr in ("inputs:shaping:focus", "inputs:shaping:ies:file"):
        a = prim.GetAttribute(attr)
        if a and a.HasAuthoredValue():
            diag.warn(f"{attr} is not supported, ignored", name)
    angle = float(_get(prim, "inputs:shaping:cone:angle", time, 90.0))
    softness = float(_get(prim, "inputs:shaping:cone:softness", time, 0.0))
    return angle, softness


# DomeLight_1 with its pole on +Z (poleAxis "Z", or "scene" on a Z-up stage): latitude
# +pi/2 is +Z and (lat 0, lon 0) is -Y.  This rotation (-90 degrees about X) takes
# that frame to the OpenEXR/+Y-pole frame the lat-long lookup uses: +Z -> +Y, -Y -> +Z.
_Z_POLE_TO_Y_POLE = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0], [0.0, -1.0, 0.0]])


def _pole_is_z(prim: Usd.Prim) -> bool:
    """True for a DomeLight_1 whose pole is +Z; the legacy DomeLight's pole is
    always +Y of its frame."""
    if not prim.IsA(UsdLux.DomeLight_1):
        return False
    pole = str(_get(prim, "poleAxis", Usd.TimeCode.Default(), "scene"))
    return pole == "Z" or (pole == "scene" and UsdGeom.GetStageUpAxis(prim.GetStage()) == UsdGeom.Tokens.z)


def read_environment(
    prim: Usd.Prim, time: Usd.TimeCode, matrix: np.ndarray, images: ImageLibrary, diag: Diagnostics
) -> Environment:
    """A DomeLight as the scene's environment: constant colour times an optional
    lat-long texture (any format OpenCV reads: .hdr, .exr, .png, ...)."""
    name = str(prim.GetPath())
    texture = -1
    file_value = _get(prim, "inputs:texture:file", time, None)
    if isinstance(file_value, Sdf.AssetPath) and file_value.path:
        fmt = str(_get(prim, "inputs:texture:format", time, "automatic"))
        if fmt not in ("automatic", "latlong"):
            diag.warn(f"dome texture format {fmt!r} is not supported; read as lat-long", name)
        image = images.image(file_value.resolvedPath or "", file_value.path, "auto", name)
        texture = images.binding(image, Wrap.REPEAT, Wrap.CLAMP)
    world_to_light = rotation_of(matrix).T
    if _pole_is_z(prim):
        world_to_light = _Z_POLE_TO_Y_POLE @ world_to_light
    world_to_light = world_to_light.astype(np.float32)
    return Environment(name=name, color=light_color(prim, time), texture=texture, world_to_light=world_to_light)


def is_dome(prim: Usd.Prim) -> bool:
    """True for DomeLight and DomeLight_1 prims."""
    return prim.IsA(UsdLux.DomeLight) or prim.IsA(UsdLux.DomeLight_1)


def read_lights(
    prims: list[Usd.Prim], time: float, xform_cache: UsdGeom.XformCache, images: ImageLibrary, diag: Diagnostics
) -> tuple[list[Light], Environment | None]:
    """All supported lights among ``prims`` (in order) and the first dome."""
    t = Usd.TimeCode(time)
    lights: list[Light] = []
    environment: Environment | None = None
    for prim in prims:
        matrix = np.array(xform_cache.GetLocalToWorldTransform(prim), dtype=np.float64)
        if is_dome(prim):
            if environment is None:
                environment = read_environment(prim, t, matrix, images, diag)
            else:
                diag.warn(
                    f"only the first DomeLight ({environment.name}) is used; this one is ignored", str(prim.GetPath())
                )
            continue
        light = read_light(prim, t, matrix, diag)
        if light is not None:
            lights.append(light)
    return lights, environment
