"""The device scene as kernels see it: one ``SceneGPU`` struct every kernel takes, so
kernel signatures stay short.  ``scene/device/upload.py`` fills these from a host
``Scene``; this module only defines the layout.
"""

from __future__ import annotations

import warp as wp

# Material flag bits (``MaterialGPU.flags``), each tested by some kernel.
FLAG_SPECULAR_WORKFLOW = wp.constant(1)
FLAG_TRANSMISSIVE = wp.constant(2)  # glass (``Material.is_glass``): tinted, with Fresnel
FLAG_REFRACTIVE = wp.constant(4)
FLAG_CUTOUT = wp.constant(8)
FLAG_VERTEX_COLOR = wp.constant(16)  # diffuse colour from ``SceneGPU.corner_colors``
FLAG_BLENDED = wp.constant(32)  # alpha-blended coverage (``Material.is_blended``), never with FLAG_TRANSMISSIVE

# Longest mip chain kept (level 15 of a 32768-texel image is 1 texel wide).
MAX_MIP_LEVELS = 16
MipOffsets = wp.types.vector(length=MAX_MIP_LEVELS, dtype=wp.int32)
# The most floats the texel pool (``SceneGPU.texels``, four a texel, every image with its
# mip chain) may hold: the kernels index its floats with 32-bit ints.
MAX_TEXEL_FLOATS = 2**31 - 1


@wp.struct
class MaterialGPU:
    """UsdPreviewSurface parameters as kernels see them (texture slots: -1 = none;
    ``normal_tex`` is a tangent-space normal map, ``Material.normal_texture``)."""

    diffuse: wp.vec3
    emissive: wp.vec3
    specular: wp.vec3
    metallic: float
    roughness: float
    opacity: float
    opacity_threshold: float
    ior: float
    flags: int
    diffuse_tex: int
    emissive_tex: int
    roughness_tex: int
    roughness_channel: int
    metallic_tex: int
    metallic_channel: int
    opacity_tex: int
    opacity_channel: int
    normal_tex: int


@wp.struct
class TextureGPU:
    """One UsdUVTexture binding: where its image starts in ``texels`` and how to sample.

    ``offset``, ``width`` and ``height`` describe mip level 0 (the image itself);
    ``levels`` counts its mip chain (1 when none was built), level L being
    ``max(1, width >> L)`` x ``max(1, height >> L)`` texels at ``level_offsets[L]``
    (see ``scene/device/mipmaps.py``; entries past the chain repeat its last level).
    ``uv_u``, ``uv_v``: the rows of the uv transform (``TextureBinding.uv_transform``):
    ``u' = dot(uv_u, (u, v, 1))``, ``v' = dot(uv_v, (u, v, 1))``."""

    offset: int
    width: int
    height: int
    levels: int
    level_offsets: MipOffsets
    wrap_s: int
    wrap_t: int
    scale: wp.vec4
    bias: wp.vec4
    uv_u: wp.vec3
    uv_v: wp.vec3


@wp.struct
class LightGPU:
    """One UsdLux light (see ``scene.model.Light``); angles are pre-converted to cosines."""

    kind: int
    color: wp.vec3
    position: wp.vec3
    direction: wp.vec3
    axis_u: wp.vec3
    axis_v: wp.vec3
    radius: float
    cos_half_angle: float
    cos_cone: float
    cone_softness: float
    normalize: int


@wp.struct
class EnvironmentGPU:
    """The dome light: constant colour times an optional lat-long texture."""

    enabled: int
    color: wp.vec3
    texture: int
    world_to_light: wp.mat33


@wp.struct
class SceneGPU:
    """Everything a kernel needs to know about the scene's geometry, materials and lights."""

    mesh: wp.uint64
    points: wp.array(dtype=wp.vec3)
    indices: wp.array(dtype=wp.int32)
    triangle_bound: wp.array(dtype=wp.float32)
    corner_normals: wp.array(dtype=wp.vec3)
    corner_uvs: wp.array(dtype=wp.vec2)
    corner_colors: wp.array(dtype=wp.vec3)
    triangle_material: wp.array(dtype=wp.int32)
    materials: wp.array(dtype=MaterialGPU)
    textures: wp.array(dtype=TextureGPU)
    texels: wp.array(dtype=wp.vec4)
    lights: wp.array(dtype=LightGPU)
    light_count: int
    environment: EnvironmentGPU


@wp.struct
class AmbientGPU:
    """The dome's ambient data (``scene/device/dome.py``; read by ``lighting/ambient.py``).

    ``sh``: 9 irradiance coefficients (dome-local frame).  ``mip_*``: levels 1..levels
    of the radiance mip chain (colour, scale and bias applied), flat vec3 texels from
    the top row; ``base_width`` is the width of level 0 (the dome texture).
    ``brdf_lut``: (roughness, n.v) -> (A, B) of ``specular_albedo_table``.
    ``sh_bands``: 1 when only the constant band is non-zero (a constant dome; the
    others are then skipped, which changes no bit of the sum), else 3.
    ``indirect``: the estimated irradiance of the lights' interreflected light
    (``lighting/indirect.py``), added to the dome's; zero when the estimate is off."""

    enabled: int
    brdf_lut: wp.array2d(dtype=wp.vec2)
    sh: wp.array(dtype=wp.vec3)
    sh_bands: int
    mip_texels: wp.array(dtype=wp.vec3)
    mip_offset: wp.array(dtype=wp.int32)
    mip_width: wp.array(dtype=wp.int32)
    mip_height: wp.array(dtype=wp.int32)
    levels: int
    base_width: int
    indirect: wp.vec3
