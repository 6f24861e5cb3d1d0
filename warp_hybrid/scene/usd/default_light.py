"""Default lighting for a stage with no lights, as usdview and usdrecord light one.

usdview/usdrecord light an unlit stage with a light at the camera (Hydra's default
"camera light", whose diffuse term is ``albedo * n.l``) plus a dim ambient term.  The
equivalent here: ``HEADLIGHT_NAME``, a distant light travelling along the default
camera's view direction with irradiance ``HEADLIGHT_IRRADIANCE`` = pi (so a white
Lambertian facing the camera has radiance 1: ``albedo / pi * E * n.l``), and
``DEFAULT_DOME_NAME``, a constant dome of radiance ``DEFAULT_DOME_RADIANCE`` = 0.1
(ambient ``0.1 albedo``, and the background).  One warning says so.

The headlight follows the scene's first camera (the default one): re-aimed when that
camera moves over time.
"""

from __future__ import annotations

import math

from ..model import Camera, Environment, Light, LightKind

HEADLIGHT_NAME = "<headlight>"
DEFAULT_DOME_NAME = "<default dome>"
HEADLIGHT_IRRADIANCE = math.pi
DEFAULT_DOME_RADIANCE = 0.1
DEFAULT_LIGHT_WARNING = (
    "no lights (no UsdLux light, no dome): lit as usdview does, by a headlight along the "
    f"default camera's view (a distant light, irradiance pi) and a dim dome (radiance {DEFAULT_DOME_RADIANCE})"
)


def headlight(camera: Camera) -> Light:
    """A distant light shining along ``camera``'s view direction, placed at the camera
    (the position only keeps the light inside the scene's frame; a distant light has none)."""
    e = HEADLIGHT_IRRADIANCE
    position = tuple(float(v) for v in camera.position)
    direction = tuple(float(v) for v in camera.forward)
    return Light(LightKind.DISTANT, HEADLIGHT_NAME, (e, e, e), position=position, direction=direction, angle_deg=0.0)


def default_dome() -> Environment:
    """The dim constant dome that goes with the headlight."""
    c = DEFAULT_DOME_RADIANCE
    return Environment(DEFAULT_DOME_NAME, (c, c, c))


def uses_default_lighting(lights: list[Light], environment: Environment | None) -> bool:
    """True when the stage gave no light and no dome (default lighting applies)."""
    return not lights and environment is None
