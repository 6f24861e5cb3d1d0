"""Host-side scene model: what a loader produces and every later stage consumes.

Everything here is plain numpy, already flattened (instances and transforms baked at
one time code), so stages never touch pxr.  Arrays use float32 for geometry and linear
colours.  Positions (points, cameras, lights) are in the scene's *local frame*: world =
local + ``Scene.origin`` (float64; 0 unless the scene lies far from the world origin
compared with its camera's near distance, ``scene.local_frame``), so float32 keeps its
precision wherever the scene sits.  ``DeviceScene`` (``scene/device/upload.py``) uploads a
``Scene`` to Warp arrays once and refits its BVH when animated points move.

Conventions (see the README): right-handed world, cameras look down their local -Z,
horizontal aperture fit, colours linear (sRGB textures are decoded at load time).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field

import numpy as np

from ..core.constants import SMOOTH_ROUGHNESS


class LightKind(enum.IntEnum):
    """Light types, mirroring UsdLux (the integer is what kernels see)."""

    DISTANT = 0
    SPHERE = 1
    RECT = 2
    DISK = 3


class Wrap(enum.IntEnum):
    """Texture wrap modes (UsdUVTexture wrapS/wrapT)."""

    REPEAT = 0
    CLAMP = 1
    MIRROR = 2
    BLACK = 3


@dataclass
class TextureImage:
    """One decoded image: (H, W, 4) float32, linear, row 0 is the *top* of the image.

    ``path`` is the resolved file, or a description for generated images (checker
    fallbacks, constant colours).
    """

    path: str
    pixels: np.ndarray

    @property
    def width(self) -> int:
        """Width in texels."""
        return int(self.pixels.shape[1])

    @property
    def height(self) -> int:
        """Height in texels."""
        return int(self.pixels.shape[0])


@dataclass
class TextureBinding:
    """A UsdUVTexture node: which image, how it wraps and its scale/bias.

    The sampled value is ``texel * scale + bias`` (UsdUVTexture semantics).  UV (0, 0)
    is the bottom-left of the image (USD convention), so sampling flips v.
    ``uv_transform`` (a, b, c, d, e, f) maps the mesh's uv to the texture's first
    (``u' = a u + b v + c``, ``v' = d u + e v + f``; UsdTransform2d nodes between the
    primvar reader and the texture), identity by default.
    """

    image: int
    wrap_s: Wrap = Wrap.REPEAT
    wrap_t: Wrap = Wrap.REPEAT
    scale: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0)
    bias: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    uv_transform: tuple[float, float, float, float, float, float] = (1.0, 0.0, 0.0, 0.0, 1.0, 0.0)


@dataclass
class Material:
    """UsdPreviewSurface parameters, linear colours.

    Texture slots hold an index into ``Scene.textures`` or -1.  Scalar slots read the
    channel given by the ``*_channel`` field (0=r, 1=g, 2=b, 3=a).  ``normal_texture``
    is a tangent-space normal map (rgb after the binding's scale and bias = x along
    dP/du, y along dP/dv, z along the interpolated normal; ``scene/device/surface.py``).
    ``diffuse_primvar``
    names the colour primvar the diffuse colour follows per corner (``Scene.corner_colors``:
    displayColor or a UsdPrimvarReader's primvar), "" for none.
    ``alpha_blended``: opacity below 1 is coverage (alpha blending: a share ``opacity``
    of the surface is there, fully shaded, and what lies behind shows through the rest,
    untinted and unbent), not glass; the USD reader sets it where a material authors
    no glass optics (``scene/usd/materials.py``).  Built by hand, a transmissive
    material is glass unless this is set.
    """

    name: str
    diffuse: tuple[float, float, float] = (0.18, 0.18, 0.18)
    emissive: tuple[float, float, float] = (0.0, 0.0, 0.0)
    specular: tuple[float, float, float] = (0.0, 0.0, 0.0)
    use_specular_workflow: bool = False
    metallic: float = 0.0
    roughness: float = 0.5
    opacity: float = 1.0
    opacity_threshold: float = 0.0
    ior: float = 1.5
    thin_walled: bool = False
    attenuation_color: tuple[float, float, float] = (1.0, 1.0, 1.0)
    attenuation_distance: float = float("inf")
    double_sided: bool = False
    diffuse_texture: int = -1
    emissive_texture: int = -1
    roughness_texture: int = -1
    roughness_channel: int = 0
    metallic_texture: int = -1
    metallic_channel: int = 0
    opacity_texture: int = -1
    opacity_channel: int = 3
    normal_texture: int = -1
    diffuse_primvar: str = ""
    alpha_blended: bool = False

    @property
    def is_vertex_colored(self) -> bool:
        """The diffuse colour comes from the per-corner colours (``Scene.corner_colors``)."""
        return bool(self.diffuse_primvar)

    @property
    def is_transmissive(self) -> bool:
        """Light passes through it (glass or a tinted pane), not an alpha cut-out."""
        return (self.opacity < 1.0 or self.opacity_texture >= 0) and self.opacity_threshold <= 0.0

    @property
    def is_blended(self) -> bool:
        """Transmissive by coverage (alpha blending, ``alpha_blended``), not glass."""
        return self.alpha_blended and self.is_transmissive

    @property
    def is_glass(self) -> bool:
        """Transmissive as glass: tinted by its colour, with Fresnel (not alpha-blended)."""
        return self.is_transmissive and not self.alpha_blended

    @property
    def is_refractive(self) -> bool:
        """Glass with bending: a solid dielectric (not thin-walled, IOR != 1)."""
        return self.is_glass and not self.thin_walled and abs(self.ior - 1.0) > 1e-6

    @property
    def is_cutout(self) -> bool:
        """Alpha-tested: fragments with opacity below the threshold are discarded."""
        return self.opacity_threshold > 0.0 and (self.opacity < 1.0 or self.opacity_texture >= 0)

    @property
    def is_reflective(self) -> bool:
        """Worth a reflection ray: metals, mirrors and smooth dielectrics."""
        return self.metallic > 0.0 or self.roughness < SMOOTH_ROUGHNESS or self.is_glass

    @property
    def is_emissive(self) -> bool:
        """Emits light (a constant colour or a texture)."""
        return max(self.emissive) > 0.0 or self.emissive_texture >= 0

    @property
    def casts_shadow(self) -> bool:
        """Shadow rays and shadow maps see its surfaces at all: every material but an
        emitter's (emitters cast no shadow)."""
        return not self.is_emissive

    def texture_slots(self) -> tuple[int, ...]:
        """Every texture slot (an index into ``Scene.textures`` or -1)."""
        return (
            self.diffuse_texture,
            self.emissive_texture,
            self.roughness_texture,
            self.metallic_texture,
            self.opacity_texture,
            self.normal_texture,
        )


@dataclass
class Light:
    """A UsdLux light in the scene's local frame, intensity already folded into ``color``.

    ``color`` = inputs:color * intensity * 2**exposure (times the colour temperature
    tint when enabled).  ``position`` is the light's origin; ``direction`` is its local
    -Z axis in world space (the way a distant light's photons travel, the way a rect,
    disk or spot light faces).  ``axis_u``/``axis_v`` span a rect light's half extents
    (world vectors of length width/2 and height/2) or a disk's radius.
    ``normalize`` follows inputs:normalize (power independent of size).
    """

    kind: LightKind
    name: str
    color: tuple[float, float, float]
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    direction: tuple[float, float, float] = (0.0, 0.0, -1.0)
    axis_u: tuple[float, float, float] = (0.0, 0.0, 0.0)
    axis_v: tuple[float, float, float] = (0.0, 0.0, 0.0)
    radius: float = 0.0
    angle_deg: float = 0.0
    cone_angle_deg: float = 180.0
    cone_softness: float = 0.0
    normalize: bool = False


@dataclass
class Environment:
    """A DomeLight: constant ``color`` (already times intensity/exposure), optionally
    times a lat-long texture (index into ``Scene.textures``).  ``world_to_light`` is
    the 3x3 rotation taking a world direction into the dome's local frame; the
    mapping from a local direction to lat-long UV is ``scene.environment_uv`` (the
    one place that convention lives, shared by host code and kernels)."""

    name: str
    color: tuple[float, float, float]
    texture: int = -1
    world_to_light: np.ndarray = field(default_factory=lambda: np.eye(3, dtype=np.float32))


@dataclass
class Camera:
    """A pinhole camera.

    ``cam_to_world`` is a 4x4 float64 matrix for column vectors
    (``p_world = cam_to_world @ [p_cam, 1]``, "world" being the scene's local frame); the camera looks down its local -Z with
    +Y up.  Field of view uses a horizontal aperture fit:
    ``tan(half hfov) = horizontal_aperture / (2 * focal_length)``; the vertical FOV
    follows from the image aspect ratio.
    """

    name: str
    cam_to_world: np.ndarray
    focal_length: float = 50.0
    horizontal_aperture: float = 36.0
    vertical_aperture: float = 24.0
    near: float = 0.01
    far: float = 1.0e6

    @property
    def tan_half_fov_x(self) -> float:
        """tan of half the horizontal field of view."""
        return self.horizontal_aperture / (2.0 * self.focal_length)

    def tan_half_fov_y(self, width: int, height: int) -> float:
        """tan of half the vertical field of view for an image of this size."""
        return self.tan_half_fov_x * height / width

    @property
    def position(self) -> np.ndarray:
        """Camera centre in world space."""
        return np.asarray(self.cam_to_world[:3, 3], dtype=np.float64)

    @property
    def forward(self) -> np.ndarray:
        """Unit viewing direction (local -Z) in world space."""
        f = -np.asarray(self.cam_to_world[:3, 2], dtype=np.float64)
        return f / np.linalg.norm(f)

    @property
    def world_to_cam(self) -> np.ndarray:
        """Inverse of ``cam_to_world``."""
        return np.linalg.inv(self.cam_to_world)


@dataclass
class MeshRange:
    """Where one source prim's triangles live in the flat arrays."""

    prim_path: str
    first_triangle: int
    triangle_count: int
    first_point: int
    point_count: int
    animated: bool = False


@dataclass
class Scene:
    """A whole scene, flattened at one time code.

    Geometry: ``points`` (N, 3) vertices in the local frame (world = points +
    ``origin``, see the module docstring); ``indices`` (T, 3) int32 into
    ``points``; ``corner_normals`` (T, 3, 3) and ``corner_uvs`` (T, 3, 2) per triangle
    corner (so any USD interpolation maps onto them); ``triangle_material`` (T,) int32
    into ``materials``.  Normals are unit length and follow the mesh orientation
    (left-handed meshes are flipped at load).  ``corner_colors`` (T, 3, 3) linear colours
    per corner, read by vertex-coloured materials (``Material.is_vertex_colored``);
    empty (0, 3, 3) when no triangle uses one.
    """

    path: str
    points: np.ndarray
    indices: np.ndarray
    corner_normals: np.ndarray
    corner_uvs: np.ndarray
    triangle_material: np.ndarray
    materials: list[Material]
    images: list[TextureImage] = field(default_factory=list)
    textures: list[TextureBinding] = field(default_factory=list)
    lights: list[Light] = field(default_factory=list)
    environment: Environment | None = None
    cameras: list[Camera] = field(default_factory=list)
    meshes: list[MeshRange] = field(default_factory=list)
    time: float = 0.0
    time_range: tuple[float, float] | None = None
    time_codes_per_second: float = 24.0
    meters_per_unit: float = 1.0
    up_axis: str = "Y"
    warnings: list[str] = field(default_factory=list)
    origin: np.ndarray = field(default_factory=lambda: np.zeros(3, dtype=np.float64))
    corner_colors: np.ndarray = field(default_factory=lambda: np.zeros((0, 3, 3), dtype=np.float32))

    @property
    def triangle_count(self) -> int:
        """Number of triangles."""
        return int(self.indices.shape[0])

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Axis-aligned bounds (min, max) of all points, in the local frame."""
        if len(self.points) == 0:
            z = np.zeros(3, dtype=np.float64)
            return z, z
        return self.points.min(axis=0).astype(np.float64), self.points.max(axis=0).astype(np.float64)
